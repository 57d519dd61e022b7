#pragma once
// A rank's part of the mesh of a distributed run. The whole mesh is numbered as one process
// numbers it: every rank's edge vertices in rank order, then every rank's centre vertices, and
// the faces in rank order; so a rank's vertices are two runs of that numbering and its faces
// one. Faces hold whole-mesh indices; a rank's faces also use vertices of the next rank (the
// edge vertices of that rank's first plane of bricks), of which it holds copies.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "qjulia/base/comm.h"
#include "qjulia/base/mesh.h"
#include "qjulia/grid/sample.h"
#include "qjulia/surface/extract.h"

namespace qjulia::detail {

/// A run of vertices in the whole mesh's numbering.
struct VertexRun {
  std::uint64_t first = 0;  ///< whole-mesh index of the first vertex
  std::uint64_t count = 0;
  std::uint64_t at = 0;  ///< ghosts: where its positions start in ghost_positions
};

struct MeshPart {
  Comm* comm = nullptr;
  int up = -1;    ///< the rank whose vertices this rank's faces also use, or -1
  int down = -1;  ///< the rank whose faces use this rank's vertices, or -1
  std::uint64_t edge_first = 0, edges = 0;      ///< this rank's edge vertices
  std::uint64_t centre_first = 0, centres = 0;  ///< its centre vertices
  std::uint64_t face_first = 0;                 ///< whole-mesh index of its first face
  std::uint64_t vertices_total = 0, faces_total = 0;
  /// The runs of this rank's vertices that the down rank's faces use (its edge vertices of its
  /// first plane of bricks, brick by brick), as local indices.
  std::vector<VertexRun> shared;
  /// Copies of the up rank's vertices (its `shared` runs) in whole-mesh numbering.
  std::vector<VertexRun> ghosts;
  std::vector<std::array<float, 3>> ghost_positions;  ///< the ghosts' positions, run by run

  /// The local index of whole-mesh vertex `v` when this rank owns it, else UINT64_MAX.
  std::uint64_t local(std::uint64_t v) const {
    if (v - edge_first < edges) return v - edge_first;
    if (v - centre_first < centres) return edges + (v - centre_first);
    return UINT64_MAX;
  }
  /// The index into ghost_positions of whole-mesh vertex `v`, a ghost. Throws when it is not.
  std::size_t ghost(std::uint64_t v) const;
  /// The position of whole-mesh vertex `v`: owned (in `mesh`) or a ghost.
  const std::array<float, 3>& position(const TriMesh& mesh, std::uint64_t v) const {
    const std::uint64_t l = local(v);
    return l != UINT64_MAX ? mesh.positions[l] : ghost_positions[ghost(v)];
  }
  /// Sends `to_down` to the down rank and `to_up` to the up rank; returns what the down and up
  /// ranks sent this one (empty where there is none). Collective.
  std::pair<std::string, std::string> swap(std::string to_down, std::string to_up) const;
};

/// extract(grid) for a grid sampled with a Distribution: this rank's part of the mesh, with
/// the normals and colours of its vertices. `stats` on rank 0 holds the whole mesh's measures
/// and component boxes; on every rank, face_component holds its faces' (whole-mesh)
/// components, and measure_valid and unembedded_cells are the whole mesh's. Collective.
TriMesh extract_part(SampledGrid&& grid, const ExtractOptions& opts, ExtractStats& stats,
                     MeshPart& part);

}  // namespace qjulia::detail
