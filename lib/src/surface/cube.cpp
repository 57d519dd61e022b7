#include "surface/cube.h"

#include <algorithm>
#include <utility>
#include <vector>

namespace qjulia::detail {

CubeTables::CubeTables() {
  for (auto& row : edge_of) row.fill(-1);
  int e = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (int d = 0; d < 8; ++d)
      if (!corner_bit(d, axis)) {
        edge_corner[e] = d;
        edge_axis[e] = axis;
        edge_of[d][d | (1 << axis)] = edge_of[d | (1 << axis)][d] = e;
        ++e;
      }
  int f = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      const int base = side << axis;
      face_corners[f] = {base, base | (1 << u), base | (1 << u) | (1 << v), base | (1 << v)};
      face_axis[f] = axis;
      face_side[f] = side;
      ++f;
    }
  for (int f2 = 0; f2 < 6; ++f2)
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) {
        const int ea = edge_of[face_corners[f2][a]][face_corners[f2][(a + 1) % 4]];
        const int eb = edge_of[face_corners[f2][b]][face_corners[f2][(b + 1) % 4]];
        share_face[ea][eb] = true;
      }
}

const CubeTables& cube() {
  static const CubeTables t;
  return t;
}

namespace {

// The ambiguous-face decider (saddle inside) for face f of a cell with values v.
bool saddle_inside(const CubeTables& t, const float v[8], int f) {
  const auto& fc = t.face_corners[f];
  const double a = v[fc[0]], b = v[fc[1]], cc = v[fc[2]], d = v[fc[3]];
  const double den = a + cc - b - d;
  return den != 0 && (a * cc - b * d) / den <= 0;
}

// The loops of a cell with the given corner signs (bit d: corner d inside) and decider answers
// (bit f: saddle of ambiguous face f inside).
CellLoops loops_of_case(int signs, int saddles) {
  float v[8];
  for (int d = 0; d < 8; ++d) v[d] = (signs >> d & 1) ? -1.0f : 1.0f;
  const CubeTables& t = cube();
  int next_of[12];
  for (int& n : next_of) n = -1;
  for (int f = 0; f < 6; ++f) {
    const auto& fc = t.face_corners[f];
    bool in[4];
    int inside = 0;
    for (int q = 0; q < 4; ++q) inside += in[q] = v[fc[q]] <= 0;
    if (inside == 0 || inside == 4) continue;
    // The crossing edges of the face, in cyclic order: edge q joins corners q and q+1.
    int crossing[4], nc = 0;
    for (int q = 0; q < 4; ++q)
      if (in[q] != in[(q + 1) % 4]) crossing[nc++] = q;
    std::pair<int, int> segs[2];  // pairs of face edge slots
    int ns = 0;
    if (nc == 2) {
      segs[ns++] = {crossing[0], crossing[1]};
    } else {
      // Ambiguous face: the asymptotic decider of the bilinear interpolant, which both cells
      // sharing the face compute alike.
      // Corner q is cut off by the segment of edges q-1 and q.
      const bool cut_inside = !(saddles >> f & 1);
      for (int q = 0; q < 4; ++q)
        if (in[q] == cut_inside) segs[ns++] = {(q + 3) % 4, q};
    }
    const int axis = t.face_axis[f];
    const double normal_sign = t.face_side[f] ? 1.0 : -1.0;
    for (int s = 0; s < ns; ++s) {
      int e1 = t.edge_of[fc[segs[s].first]][fc[(segs[s].first + 1) % 4]];
      int e2 = t.edge_of[fc[segs[s].second]][fc[(segs[s].second + 1) % 4]];
      // Midpoints of the edges and an inside corner, in cube-local coordinates.
      auto mid = [&](int e, int a2) {
        const int d0 = t.edge_corner[e];
        return a2 == t.edge_axis[e] ? 0.5 : static_cast<double>(corner_bit(d0, a2));
      };
      // A corner on the inside of the segment: with two crossings any inside corner of the
      // face; a segment of an ambiguous face cuts off corner `second`, and when that corner is
      // outside, its neighbour is inside.
      int inside_corner = -1;
      if (nc == 4) {
        const int q = segs[s].second;
        inside_corner = fc[in[q] ? q : (q + 1) % 4];
      } else {
        for (int q = 0; q < 4 && inside_corner < 0; ++q)
          if (in[q]) inside_corner = fc[q];
      }
      double m1[3], dv[3], cv[3];
      for (int a2 = 0; a2 < 3; ++a2) {
        m1[a2] = mid(e1, a2);
        dv[a2] = mid(e2, a2) - m1[a2];
        cv[a2] = corner_bit(inside_corner, a2) - m1[a2];
      }
      // (n x d) . c with n = normal_sign * e_axis.
      const int u = (axis + 1) % 3, w = (axis + 2) % 3;
      const double nxd_u = -normal_sign * dv[w];
      const double nxd_w = normal_sign * dv[u];
      const double left = nxd_u * cv[u] + nxd_w * cv[w];
      if (left > 0) std::swap(e1, e2);  // the inside must be on the right
      next_of[e1] = e2;
    }
  }
  // Chain the segments into loops.
  CellLoops out;
  bool used[12] = {};
  for (int start = 0; start < 12; ++start) {
    if (next_of[start] < 0 || used[start]) continue;
    int len = 0;
    int* loop = out.edge[out.count];
    for (int e = start; !used[e] && len < 12; e = next_of[e]) {
      used[e] = true;
      loop[len++] = e;
      if (next_of[e] < 0) break;
    }
    if (len < 3) continue;
    out.length[out.count++] = len;
  }
  return out;
}

// Faces with four crossings for each sign pattern.
struct CaseTable {
  std::uint8_t ambiguous[256] = {};
  std::uint16_t index[256][64] = {};
  std::vector<CellCase> cases;
  CaseTable() {
    const CubeTables& t = cube();
    for (int signs = 0; signs < 256; ++signs)
      for (int f = 0; f < 6; ++f) {
        const auto& fc = t.face_corners[f];
        int changes = 0;
        for (int q = 0; q < 4; ++q)
          changes += (signs >> fc[q] & 1) != (signs >> fc[(q + 1) % 4] & 1);
        if (changes == 4) ambiguous[signs] |= static_cast<std::uint8_t>(1u << f);
      }
    std::size_t count = 0;  // a case for each answer of each ambiguous face
    for (int signs = 0; signs < 256; ++signs)
      count += std::size_t{1} << __builtin_popcount(ambiguous[signs]);
    cases.reserve(count);
    for (int signs = 0; signs < 256; ++signs)
      for (int saddles = 0; saddles < 64; ++saddles) {
        if (saddles & ~ambiguous[signs]) continue;
        index[signs][saddles] = static_cast<std::uint16_t>(cases.size());
        cases.push_back(build(loops_of_case(signs, saddles)));
      }
  }
  static CellCase build(const CellLoops& l) {
    const CubeTables& t = cube();
    CellCase c;
    c.loops = static_cast<std::uint8_t>(l.count);
    for (int L = 0; L < l.count; ++L) {
      const int len = l.length[L];
      c.length[L] = static_cast<std::uint8_t>(len);
      for (int q = 0; q < len; ++q) {
        c.edge[L][q] = static_cast<std::uint8_t>(l.edge[L][q]);
        const int e1 = l.edge[L][q], e2 = l.edge[L][(q + 1) % len];
        for (int f = 0; f < 6; ++f) {
          const auto& fc = t.face_corners[f];
          bool has1 = false, has2 = false;
          for (int k = 0; k < 4; ++k) {
            const int e = t.edge_of[fc[k]][fc[(k + 1) % 4]];
            has1 = has1 || e == e1;
            has2 = has2 || e == e2;
          }
          if (has1 && has2) c.face[L][q] = static_cast<std::uint8_t>(f);
        }
      }
      c.triangles[L] = static_cast<std::uint8_t>(triangulate_loop(
          l.edge[L], len, [](int, int) { return 0.0; }, c.tri[L]));
      if (c.triangles[L] > 1) find_view(c, L);
    }
    return c;
  }
  // The axis along which loop L's triangulation looks one-to-one, and the orders within the
  // view's sides that this needs (the fewest of the three axes; none when no axis does it).
  // Looked at along axis k, the rectangle of the other two axes (u, w) is walked
  // counter-clockwise from its corner (lo u, lo w): side 0 is w = lo, 1 u = hi, 2 w = hi, 3
  // u = lo. A point on an edge along k sits at the corner a side starts with; a point on another
  // edge inside a side. The places must go round once strictly (either way), so points in one
  // side, next to each other in the loop, must be in the order of the walk. No triangle has its
  // three points on one closed side (which would be flat in the view): those points all lie on
  // one face of the cube, and the triangulation joins no two such points by a diagonal.
  static void find_view(CellCase& c, int L) {
    const CubeTables& t = cube();
    const int len = c.length[L];
    int best_orders = 13;
    for (int k = 0; k < 3; ++k) {
      const int u = (k + 1) % 3, w = (k + 2) % 3;
      int key[12];
      bool increasing[12];  // along the walk as the coordinate grows (points inside a side)
      for (int q = 0; q < len; ++q) {
        const int e = c.edge[L][q], d0 = t.edge_corner[e], j = t.edge_axis[e];
        const int bu = corner_bit(d0, u), bw = corner_bit(d0, w);
        int side;
        if (j == k) {
          side = bu ? (bw ? 2 : 1) : (bw ? 3 : 0);
          key[q] = 2 * side;
        } else {
          side = j == u ? (bw ? 2 : 0) : (bu ? 1 : 3);
          key[q] = 2 * side + 1;
          increasing[q] = side == 0 || side == 1;
        }
      }
      int up = 0, down = 0;
      for (int q = 0; q < len; ++q) {
        const int a = key[q], b = key[(q + 1) % len];
        up += a < b;
        down += a > b;
      }
      // Counter-clockwise: one step back (the wrap); clockwise: one step forward.
      const bool ccw = down == 1;
      if (!ccw && up != 1) continue;
      std::uint8_t order[12][2];
      int orders = 0;
      for (int q = 0; q < len; ++q) {
        const int n = (q + 1) % len;
        if (key[q] != key[n]) continue;
        // Two points inside one side (corners have distinct keys): the later one in the loop
        // further along the walk when counter-clockwise, back along it when clockwise.
        const bool later_greater = increasing[q] == ccw;
        order[orders][0] = static_cast<std::uint8_t>(later_greater ? q : n);
        order[orders][1] = static_cast<std::uint8_t>(later_greater ? n : q);
        ++orders;
      }
      if (orders < best_orders) {
        best_orders = orders;
        c.view_axis[L] = static_cast<std::uint8_t>(k);
        c.view_orders[L] = static_cast<std::uint8_t>(orders);
        std::copy(&order[0][0], &order[0][0] + 2 * orders, &c.view_order[L][0][0]);
      }
    }
  }
};

const CaseTable& case_table() {
  static const CaseTable table;
  return table;
}

}  // namespace

CellLoops cell_loops(const float v[8]) {
  const CubeTables& t = cube();
  int saddles = 0;
  const int signs = signs_of(v);
  const int amb = case_table().ambiguous[signs];
  for (int f = 0; f < 6; ++f)
    if (amb >> f & 1) saddles |= saddle_inside(t, v, f) << f;
  return loops_of_case(signs, saddles);
}

const CellCase& cell_case(const float v[8]) { return cell_case_at(cell_case_index(v)); }

const CellCase& cell_case_at(std::uint16_t index) { return case_table().cases[index]; }

bool loop_embedded(const CellCase& cc, int L, const std::array<double, 3>* pts,
                   const std::array<double, 3>& lo, const std::array<double, 3>& hi) {
  if (cc.view_axis[L] > 2) return false;
  const CubeTables& t = cube();
  bool ok = true;
  for (int q = 0; q < cc.length[L]; ++q) {
    const int e = cc.edge[L][q], d0 = t.edge_corner[e], j = t.edge_axis[e];
    const std::array<double, 3>& p = pts[q];
    for (int a = 0; a < 3; ++a)
      ok &= a == j ? (p[a] > lo[a]) & (p[a] < hi[a]) : p[a] == (corner_bit(d0, a) ? hi[a] : lo[a]);
  }
  for (int o = 0; o < cc.view_orders[L]; ++o) {
    const int a = cc.view_order[L][o][0], b = cc.view_order[L][o][1];
    const int j = t.edge_axis[cc.edge[L][a]];
    ok &= pts[a][j] < pts[b][j];
  }
  return ok;
}

int signs_of(const float v[8]) {
  int s = 0;
  for (int d = 0; d < 8; ++d) s |= (v[d] <= 0) << d;
  return s;
}

std::uint16_t cell_case_index(const float v[8]) {
  const CaseTable& table = case_table();
  const int signs = signs_of(v);
  const int amb = table.ambiguous[signs];
  int saddles = 0;
  if (amb) {
    const CubeTables& t = cube();
    for (int f = 0; f < 6; ++f)
      if (amb >> f & 1) saddles |= saddle_inside(t, v, f) << f;
  }
  return table.index[signs][saddles];
}

}  // namespace qjulia::detail
