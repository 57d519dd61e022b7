#pragma once
// Marching cubes over one brick, in two passes so the mesh is written in place: first the
// vertices on the crossing grid edges the brick owns (their lower point is in the brick), moved
// onto the exact boundary, with the counts of the triangles and centre vertices its cells will
// make; then, once every brick's vertices are numbered, the triangles, whose corners on edges
// owned by a neighbour are found by the neighbour's edge codes, so bricks weld by an exact key
// join.
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

/// Options of the meshing passes.
struct BrickMeshOptions {
  double tolerance = 0.02;  ///< bracket length at which refinement stops, voxels
  int max_refine_steps = 24;
};

/// The first pass over a brick.
struct BrickVertices {
  std::uint64_t key = 0;
  std::vector<std::array<float, 3>> positions;  ///< owned edge vertices, by ascending code
  std::vector<std::uint16_t> codes;             ///< their edge codes
  std::uint32_t triangles = 0;                  ///< the triangles the second pass writes
  std::uint32_t centres = 0;                    ///< the centre vertices it adds
  std::uint64_t evaluations = 0;                ///< classifier calls
};

/// The vertices of the surface cells of `brick` on the edges it owns (every corner of a
/// surface cell must be known), and the counts of the second pass.
BrickVertices brick_vertices(const Brick& brick, const Solid& solid, const GridGeometry& geo,
                             const BrickMeshOptions& opts);

/// Where the second pass reads vertices and writes its results.
struct MeshTarget {
  std::array<float, 3>* positions = nullptr;          ///< the mesh's positions (edge vertices set)
  std::array<std::uint32_t, 3>* triangles = nullptr;  ///< the mesh's triangles
  std::size_t vertex_base = 0;                        ///< index of the brick's first edge vertex
  std::size_t centre_base = 0;                        ///< index of its first centre vertex
  std::size_t face_base = 0;                          ///< index of its first triangle
  /// The neighbours in direction bits (x = 1, y = 2, z = 4, towards +): their edge codes and
  /// first vertex; [0] is the brick itself.
  const std::vector<std::uint16_t>* codes[8] = {};
  std::size_t base[8] = {};
};

/// The second pass's results besides the written triangles and centre vertices.
struct BrickFaces {
  /// The triangle edges on a face of the brick (-x, +x, -y, +y, -z, +z: 2 * axis + side) as
  /// (from, to) vertex indices in the triangles' orientation: the neighbour across that face has
  /// each of them the other way round.
  std::vector<std::array<std::uint32_t, 2>> border[6];
  std::uint64_t evaluations = 0;
};

/// The triangles of the surface cells of `brick` (and their centre vertices), written at the
/// target's bases. Writes exactly the counts the first pass gave.
BrickFaces brick_triangles(const Brick& brick, const Solid& solid, const GridGeometry& geo,
                           const BrickMeshOptions& opts, const MeshTarget& target);

}  // namespace qjulia::detail
