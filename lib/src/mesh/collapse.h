#pragma once
/// @file collapse.h
/// The fast decimation's simplifier: edge collapses by quadric error that keep the surface's
/// topology (the link condition) and its orientation (no face turned over).
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "qjulia/base/mesh.h"

namespace qjulia::detail {

struct CollapseOptions {
  std::size_t target_faces = 0;  ///< stop at this many faces or fewer
  /// Stop where the cheapest collapse moves the surface by more than this (model units, the
  /// root of the area-weighted mean squared distance to the planes of the merged faces).
  double max_error = 1e30;
  /// Vertices never removed (they may receive collapses); empty: none.
  const std::vector<uint8_t>* locked = nullptr;
  const CancelToken* cancel = nullptr;
};

/// Simplifies `mesh` by half-edge collapses (a vertex merged into a neighbour, whose position is
/// kept), cheapest first by the quadric error of Garland and Heckbert. A collapse is made only
/// where it keeps the topology: the two vertices share exactly the two neighbours of their edge,
/// and no face of one coincides with a face of the other after it; and where no face turns over
/// or degenerates. The vertices of edges with one face and of non-manifold fans must be locked
/// by the caller, together with their neighbours (so no collapse reaches them), for the result
/// to keep the shape of the input. Returns the remaining faces, indexing mesh.positions. The
/// result depends only on the input and the options.
std::vector<std::array<uint32_t, 3>> collapse_edges(const TriMesh& mesh,
                                                    const CollapseOptions& opts);

}  // namespace qjulia::detail
