#pragma once
// The cube of marching cubes: its corners, edges and faces, the loops in which the surface
// crosses a cell, and their triangulation.
#include <array>
#include <cstdint>

namespace qjulia::detail {

/// Corner d of a cell sits at offset (d & 1, d >> 1 & 1, d >> 2 & 1).
inline int corner_bit(int d, int axis) { return (d >> axis) & 1; }

/// The twelve edges as (lower corner, axis), the four corners of each face in cyclic order
/// with the face's normal axis and side, and which edges share a face.
struct CubeTables {
  std::array<int, 12> edge_corner{};
  std::array<int, 12> edge_axis{};
  std::array<std::array<int, 4>, 6> face_corners{};
  std::array<int, 6> face_axis{}, face_side{};
  std::array<std::array<int, 8>, 8> edge_of{};  ///< corner pair -> edge, -1 if not an edge
  std::array<std::array<bool, 12>, 12> share_face{};
  CubeTables();
};

/// The tables (built once).
const CubeTables& cube();

/// The surface in one cell: closed loops of crossing edges, each oriented so the inside is on
/// the right seen from outside the cell (counter-clockwise seen from outside the solid).
/// Ambiguous faces are decided by the asymptotic decider of the bilinear interpolant, which the
/// two cells that share a face compute alike.
struct CellLoops {
  int count = 0;
  int length[4] = {};
  int edge[4][12] = {};  ///< cube edges in loop order
};

/// The loops of a cell with corner values v (inside where v <= 0).
CellLoops cell_loops(const float v[8]);

/// Everything marching cubes needs of a cell, by the signs of its corners and the decider's
/// answers on its ambiguous faces (computed once per case): the loops, the cube face of each
/// loop segment (from edge q to q + 1), and each loop's triangulation without a diagonal on a
/// cube face (none: a centre vertex is needed).
struct CellCase {
  std::uint8_t loops = 0;
  std::uint8_t length[4] = {};
  std::uint8_t edge[4][12] = {};
  std::uint8_t face[4][12] = {};
  std::uint8_t triangles[4] = {};  ///< length - 2, or 0 for a centre vertex
  std::uint8_t tri[4][30] = {};    ///< loop positions, three per triangle
  /// For a loop whose triangulation above (two triangles or more) looks one-to-one along one of
  /// the cell's axes whatever its points' places on their edges, but for the order of points
  /// that the view puts on one side of the cell: that axis (else 3), and those orders (loop
  /// positions a, b: b is further along their edges' axis than a). See loop_embedded().
  std::uint8_t view_axis[4] = {3, 3, 3, 3};
  std::uint8_t view_orders[4] = {};
  std::uint8_t view_order[4][12][2] = {};
};

/// The corners of a cell with corner values v that are inside (v <= 0), as bits (corner d is
/// bit d).
int signs_of(const float v[8]);
/// The case of a cell with corner values v.
const CellCase& cell_case(const float v[8]);
/// The number of that case, and the case of a number.
std::uint16_t cell_case_index(const float v[8]);
const CellCase& cell_case_at(std::uint16_t index);

/// True when the triangulation of loop L of case cc with its points at pts (in loop order),
/// in the cell [lo, hi], is proved embedded: each point lies on its cube edge (its other two
/// coordinates those of the edge's corner, exactly) strictly between the corners, and the
/// orders of CellCase::view_order hold. Looked at along view_axis, the points then lie on the
/// boundary of the cell's rectangle in strict cyclic order and no triangle along one side, so
/// the triangles map one-to-one onto a convex polygon: no two of them meet other than in their
/// common corners and edges (triangles_cross() is false for every pair). False when that is not
/// shown (no view axis, or a condition fails): the pairs must then be tested. Comparisons only.
bool loop_embedded(const CellCase& cc, int L, const std::array<double, 3>* pts,
                   const std::array<double, 3>& lo, const std::array<double, 3>& hi);

/// Triangulates a loop of `len` (<= 12) cube edges so that no new edge joins two cube edges that
/// share a face (the neighbour cell could make the same edge), by dynamic programming over
/// sub-polygons; `weight(i, j)` is the cost of the diagonal between loop positions i and j (the
/// triangulation of least total cost is chosen). Writes loop positions, three per triangle,
/// oriented like the loop. Returns the triangle count (len - 2), or 0 when no such
/// triangulation exists.
template <class Weight>
int triangulate_loop(const int* loop, int len, Weight&& weight, std::uint8_t* out) {
  const auto& share = cube().share_face;
  auto allowed = [&](int i, int j) {
    return j - i == 1 || (i == 0 && j == len - 1) || !share[loop[i]][loop[j]];
  };
  // cost[i][j]: least cost of triangulating the sub-polygon i..j (j - i >= 2), or infinite;
  // split[i][j]: the apex k of the triangle (i, k, j) on diagonal i-j.
  double cost[12][12];
  int split[12][12];
  for (int i = 0; i + 1 < len; ++i) cost[i][i + 1] = 0;
  for (int gap = 2; gap < len; ++gap)
    for (int i = 0; i + gap < len; ++i) {
      const int j = i + gap;
      cost[i][j] = 1e300;
      split[i][j] = -1;
      if (!allowed(i, j)) continue;
      const double wij = (j - i == len - 1) ? 0.0 : weight(i, j);
      for (int k = i + 1; k < j; ++k) {
        if (cost[i][k] >= 1e300 || cost[k][j] >= 1e300) continue;
        const double c = cost[i][k] + cost[k][j] + wij;
        if (c < cost[i][j]) {
          cost[i][j] = c;
          split[i][j] = k;
        }
      }
    }
  if (split[0][len - 1] < 0) return 0;
  int n = 0;
  int stack[24][2], top = 0;
  stack[top][0] = 0;
  stack[top++][1] = len - 1;
  while (top > 0) {
    --top;
    const int i = stack[top][0], j = stack[top][1];
    if (j - i < 2) continue;
    const int k = split[i][j];
    out[3 * n] = static_cast<std::uint8_t>(i);
    out[3 * n + 1] = static_cast<std::uint8_t>(k);
    out[3 * n + 2] = static_cast<std::uint8_t>(j);
    ++n;
    stack[top][0] = i;
    stack[top++][1] = k;
    stack[top][0] = k;
    stack[top++][1] = j;
  }
  return n;
}

}  // namespace qjulia::detail
