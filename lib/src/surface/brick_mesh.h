#pragma once
// Marching cubes over one brick, in passes so the mesh is written in place: first the vertices
// on the crossing grid edges the brick owns (their lower point is in the brick), moved onto the
// exact boundary; then, with the neighbours' vertices at hand, the plan of each cell (which
// triangulation keeps the surface embedded, and the centre vertices); then, once every brick's
// vertices are numbered, the triangles, whose corners on edges owned by a neighbour are found
// by the neighbour's edge codes, so bricks weld by an exact key join.
#include <array>
#include <cstdint>
#include <utility>
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

/// A loop triangulated otherwise than by the table: so that the cell's triangles do not cross.
struct LoopChoice {
  std::uint16_t cell = 0;  ///< local cell index
  std::uint8_t loop = 0;   ///< the loop in the cell's case
  std::uint8_t count = 0;  ///< triangles in `tri`; 0: around a centre vertex
  std::uint8_t tri[30] = {};
};

/// The first pass over a brick: the vertices on the crossing edges it owns.
struct BrickVertices {
  std::uint64_t key = 0;
  std::vector<std::array<float, 3>> positions;  ///< owned edge vertices, by ascending code
  std::vector<std::uint16_t> codes;             ///< their edge codes
  /// The surface cells in order, each as (local cell << 16) | its case number: all the plan
  /// needs of the brick's values, so the brick can go after this pass.
  std::vector<std::uint32_t> cells;
  std::uint64_t evaluations = 0;  ///< classifier calls
};

/// The vertices on the crossing edges of the surface cells of each of the n bricks that it owns
/// (every corner of a surface cell must be known), moved onto the boundary, and the cases of
/// its surface cells: out[b] for bricks[b]. The group's vertices are refined together, in shared
/// batches of evaluations (all counted in out[0].evaluations).
void brick_vertices(const Brick* const* bricks, std::size_t n, const Solid& solid,
                    const GridGeometry& geo, const BrickMeshOptions& opts, BrickVertices* out);

/// The edge vertices around a brick: its own and those of its neighbours in direction bits
/// (x = 1, y = 2, z = 4, towards +; [0] is the brick itself), numbered from `base`.
struct BrickNeighbours {
  const std::vector<std::uint16_t>* codes[8] = {};
  const std::array<float, 3>* positions[8] = {};  ///< may be null where only indices are needed
  std::size_t base[8] = {};
  /// The direction and index in it of the vertex on local edge `code`; throws when missing.
  std::pair<int, std::size_t> find(int code) const;
};

/// How the cells of a brick are triangulated: the table's way, except where listed.
struct BrickPlan {
  /// The surface cells in order, each as (local cell << 16) | its case number (the first
  /// pass's, BrickVertices::cells).
  std::vector<std::uint32_t> cells;
  std::vector<std::array<float, 3>> centres;  ///< centre vertices, in the order of the cells
  std::vector<LoopChoice> choices;            ///< by cell, then loop
  std::uint32_t triangles = 0;                ///< the triangles the second pass writes
  std::size_t unmended = 0;                   ///< cells whose triangles cross whatever was tried
  std::uint64_t evaluations = 0;
};

/// The plan of each surface cell (`cells`, as BrickVertices::cells) of the brick at `at`: every
/// loop is triangulated without a diagonal on a cube face (the neighbour cell could make the
/// same edge), by the table's triangulation when the cell's triangles then do not cross, else by
/// another (least area first) or around a centre vertex on the boundary inside the cell. Reads
/// the edge vertices of `around`; the plan keeps `cells`.
BrickPlan plan_brick(const BrickCoord& at, std::vector<std::uint32_t> cells, const Solid& solid,
                     const GridGeometry& geo, const BrickMeshOptions& opts,
                     const BrickNeighbours& around);

/// Where the second pass reads vertices and writes its results.
struct MeshTarget {
  std::array<std::uint32_t, 3>* triangles = nullptr;  ///< the mesh's triangles
  std::size_t centre_base = 0;                        ///< index of the brick's first centre vertex
  std::size_t face_base = 0;                          ///< index of its first triangle
  BrickNeighbours around;                             ///< the vertex numbers around the brick
};

/// The second pass's results besides the written triangles.
struct BrickFaces {
  /// The triangle edges on a face of the brick (-x, +x, -y, +y, -z, +z: 2 * axis + side) as
  /// (from, to) vertex indices in the triangles' orientation: the neighbour across that face has
  /// each of them the other way round.
  std::vector<std::array<std::uint32_t, 2>> border[6];
};

/// The triangles of a brick's surface cells by its plan, written at the target's bases.
/// Writes exactly the plan's count.
BrickFaces brick_triangles(const BrickPlan& plan, const MeshTarget& target);

}  // namespace qjulia::detail
