#pragma once
// Marching cubes over one brick: its vertices (one per crossing grid edge it owns, moved onto
// the exact boundary) and its triangles, whose corners on edges owned by a neighbour brick are
// named by the neighbour and the edge, so bricks weld by an exact key join.
#include <array>
#include <cstdint>
#include <vector>

#include "grid/bricks.h"
#include "qjulia/field/classify.h"
#include "qjulia/grid/sample.h"

namespace qjulia::detail {

/// A local edge code: the edge's lower point in the brick's 9^3 points and its axis.
inline int edge_code(int i, int j, int k, int axis) { return point_index(i, j, k) * 3 + axis; }
constexpr int kEdgeCodes = kBrickPoints * 3;

/// A triangle corner: the index of a vertex of this brick, or (with kForeign) the neighbour
/// brick in direction bits (x = 1, y = 2, z = 4, towards +) and its edge code.
constexpr std::uint32_t kForeign = 1u << 31;
inline std::uint32_t foreign_ref(int dir, int code) {
  return kForeign | (static_cast<std::uint32_t>(dir) << 12) | static_cast<std::uint32_t>(code);
}

/// The mesh of one brick.
struct BrickMesh {
  std::uint64_t key = 0;
  /// Edge vertices (sorted by edge code), then the centre vertices of cells whose loop needed
  /// one.
  std::vector<std::array<float, 3>> positions;
  std::vector<std::uint16_t> codes;  ///< edge codes of the edge vertices, ascending
  std::vector<std::array<std::uint32_t, 3>> triangles;
  /// The triangle edges that lie on a face of the brick (from -x, +x, -y, +y, -z, +z: index
  /// 2 * axis + side), as (from, to) corners in the triangles' orientation: the neighbour across
  /// that face has each of them the other way round.
  std::vector<std::array<std::uint32_t, 2>> border[6];
  std::uint64_t evaluations = 0;  ///< classifier calls for the vertices
};

/// Options of mesh_brick().
struct BrickMeshOptions {
  double tolerance = 0.02;  ///< bracket length at which refinement stops, voxels
  int max_refine_steps = 24;
};

/// Meshes the surface cells of `brick`. Every corner of a surface cell must be known.
BrickMesh mesh_brick(const Brick& brick, const Solid& solid, const GridGeometry& geo,
                     const BrickMeshOptions& opts);

}  // namespace qjulia::detail
