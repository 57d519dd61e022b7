#pragma once
/// @file decimate_openmesh.h
/// decimate()'s quality method: OpenMesh's Decimater (kept apart: OpenMesh's templates compile
/// slowly).
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "qjulia/base/mesh.h"
#include "qjulia/base/progress.h"

namespace qjulia::detail {

/// What decimate_openmesh() does.
struct OpenMeshDecimation {
  std::size_t target_faces = 0;      ///< stop at this many faces; 0 = as far as the bounds allow
  double tolerance = 0;              ///< ModHausdorff bound to the input, model units; 0 = none
  double max_normal_deviation = 45;  ///< ModNormalFlipping bound per collapse, degrees
  /// Per input vertex (empty or #V): kept, with its faces, exactly as it is.
  const std::vector<uint8_t>* pinned = nullptr;
  const CancelToken* cancel = nullptr;
  /// Called with the fraction of the collapses done; returning false cancels.
  ProgressFn progress;
};

/// Halfedge collapses ordered by ModQuadric's error, each one allowed only when it keeps the
/// mesh manifold (OpenMesh's link condition), turns no face normal by more than
/// max_normal_deviation and (with a tolerance) keeps every removed input vertex within the
/// tolerance of the result (ModHausdorff). The faces around vertices that are non-manifold or
/// misoriented in the input, faces with a repeated index and the faces of pinned vertices are
/// left out and put back unchanged, with the rim of the hole they leave locked. The vertices of
/// the result are input vertices at their input positions.
/// @return the triangles of the result, indexing mesh.positions.
/// @throws Cancelled when opts.cancel is requested or opts.progress returns false.
std::vector<std::array<uint32_t, 3>> decimate_openmesh(const TriMesh& mesh,
                                                       const OpenMeshDecimation& opts);

}  // namespace qjulia::detail
