// triangles_cross() certifies most answers in floating point before CGAL's exact predicates;
// whatever it answers must be what the exact predicates alone answer.
#include "surface/embed.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/intersections.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "surface/cube.h"

namespace qjulia::detail {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using P = std::array<double, 3>;

Point point(const P& p) { return Point(p[0], p[1], p[2]); }

// The rules of triangles_cross() by CGAL's exact predicates alone.
bool exact_cross(const Triangle& a, const Triangle& b) {
  const Point pa[3] = {point(a[0]), point(a[1]), point(a[2])};
  const Point pb[3] = {point(b[0]), point(b[1]), point(b[2])};
  // a's corner i is b's corner at[i], or -1 (the corners of each are distinct).
  int at[3], shared = 0;
  for (int i = 0; i < 3; ++i) {
    const auto it = std::find(b.begin(), b.end(), a[i]);
    at[i] = it == b.end() ? -1 : static_cast<int>(it - b.begin());
    shared += at[i] >= 0;
  }
  if (shared >= 3) return true;
  if (shared == 2) {
    int p = 0;
    while (at[p] >= 0) ++p;
    int q = 0;
    while (q == at[(p + 1) % 3] || q == at[(p + 2) % 3]) ++q;
    const Point& u = pa[(p + 1) % 3];
    const Point& v = pa[(p + 2) % 3];
    return CGAL::coplanar(u, v, pa[p], pb[q]) &&
           CGAL::coplanar_orientation(u, v, pa[p], pb[q]) == CGAL::POSITIVE;
  }
  const K::Triangle_3 ta(pa[0], pa[1], pa[2]), tb(pb[0], pb[1], pb[2]);
  if (shared == 1) {
    int i = 0;
    while (at[i] < 0) ++i;
    const int j = at[i];
    const K::Segment_3 sa(pa[(i + 1) % 3], pa[(i + 2) % 3]), sb(pb[(j + 1) % 3], pb[(j + 2) % 3]);
    return CGAL::do_intersect(ta, sb) || CGAL::do_intersect(tb, sa);
  }
  return CGAL::do_intersect(ta, tb);
}

// Points on a coarse lattice (so that many quadruples are exactly coplanar), some moved by a
// few units in the last place (nearly coplanar), in a cell-sized box away from the origin.
struct Points {
  std::mt19937_64 rng{20261205};
  P next() {
    std::uniform_int_distribution<int> lattice(0, 4);
    std::uniform_int_distribution<int> nudge(-3, 3);
    std::uniform_int_distribution<int> coin(0, 3);
    P p;
    for (int k = 0; k < 3; ++k) {
      p[k] = 0.3 + lattice(rng) * (0.0058 / 4);
      if (coin(rng) == 0)
        for (int n = nudge(rng); n != 0; n += n > 0 ? -1 : 1)
          p[k] = std::nextafter(p[k], n > 0 ? 1.0 : -1.0);
    }
    return p;
  }
};

TEST(Embed, TheCertifiedAnswersAreTheExactOnes) {
  Points pts;
  int crossing[4] = {0, 0, 0, 0}, total[4] = {0, 0, 0, 0};
  for (int round = 0; round < 200000; ++round) {
    const int shared = round % 3;  // corners the two triangles have in common
    Triangle a{pts.next(), pts.next(), pts.next()};
    Triangle b{pts.next(), pts.next(), pts.next()};
    for (int s = 0; s < shared; ++s) b[s] = a[(s + round / 3) % 3];
    std::swap(b[0], b[(round / 7) % 3]);
    // A mesh's triangles have three corners not on one line (CGAL's intersection tests
    // require it).
    if (CGAL::collinear(point(a[0]), point(a[1]), point(a[2])) ||
        CGAL::collinear(point(b[0]), point(b[1]), point(b[2])))
      continue;
    const bool expected = exact_cross(a, b);
    ASSERT_EQ(triangles_cross(a, b), expected) << "round " << round;
    ASSERT_EQ(triangles_cross(b, a), exact_cross(b, a)) << "round " << round;
    ++total[shared];
    crossing[shared] += expected;
  }
  // Both answers came up often for every kind of pair (folds are the rarest: about 1% of the
  // pairs with an edge in common), so both sides of each shortcut were tried.
  for (int shared = 0; shared < 3; ++shared) {
    SCOPED_TRACE(shared);
    EXPECT_GT(crossing[shared], 100);
    EXPECT_GT(total[shared] - crossing[shared], 100);
  }
}

TEST(Embed, AFoldInOnePlaneCrossesAndAFlatPairDoesNot) {
  const P u{0.3, 0.3, 0.3}, v{0.31, 0.3, 0.3};
  const P above{0.305, 0.31, 0.3}, above2{0.302, 0.305, 0.3}, below{0.305, 0.29, 0.3};
  EXPECT_TRUE(triangles_cross({u, v, above}, {v, u, above2}));   // folded onto each other
  EXPECT_FALSE(triangles_cross({u, v, above}, {v, u, below}));   // flat, side by side
  P lifted = above2;
  lifted[2] = std::nextafter(lifted[2], 1.0);  // out of the plane by one unit: no fold
  EXPECT_FALSE(triangles_cross({u, v, above}, {v, u, lifted}));
}

// A loop of a cell's case with its points on their edges: at random places, on a coarse
// lattice of places (points in one plane or one line of the view), or at an end of the edge.
struct CellLoop {
  P lo, hi;
  P pts[12];
  std::vector<Triangle> triangles;
  // Places the points of loop L of cc in the cell at `lo` of side `voxel`, as the mesh holds
  // coordinates (floats); `end` puts the first point at its edge's lower corner.
  CellLoop(const CellCase& cc, int L, std::mt19937_64& rng, bool lattice, bool end) {
    const P base{0.3, -0.7, 1.1};
    const double voxel = 0.0058;
    for (int a = 0; a < 3; ++a) {
      lo[a] = static_cast<float>(base[a]);
      hi[a] = static_cast<float>(base[a] + voxel);
    }
    std::uniform_real_distribution<double> t(0.001, 0.999);
    std::uniform_int_distribution<int> step(1, 3);
    const CubeTables& ct = cube();
    for (int q = 0; q < cc.length[L]; ++q) {
      const int e = cc.edge[L][q], d0 = ct.edge_corner[e], j = ct.edge_axis[e];
      for (int a = 0; a < 3; ++a) pts[q][a] = corner_bit(d0, a) ? hi[a] : lo[a];
      const double f = end && q == 0 ? 0.0 : lattice ? step(rng) / 4.0 : t(rng);
      pts[q][j] = static_cast<float>(lo[j] + f * (hi[j] - lo[j]));
    }
    for (int tr = 0; tr < cc.triangles[L]; ++tr) {
      const std::uint8_t* i = cc.tri[L] + 3 * tr;
      triangles.push_back({pts[i[0]], pts[i[1]], pts[i[2]]});
    }
  }
  bool no_pair_crosses() const {
    for (std::size_t i = 0; i < triangles.size(); ++i)
      for (std::size_t j = i + 1; j < triangles.size(); ++j)
        if (exact_cross(triangles[i], triangles[j])) return false;
    return true;
  }
};

TEST(Embed, ALoopProvedEmbeddedByItsViewHasNoCrossingPair) {
  std::mt19937_64 rng(20261207);
  std::uniform_real_distribution<float> value(-1.0f, 1.0f);
  int loops = 0, proved = 0, crossing = 0, unordered = 0;
  for (int round = 0; round < 20000; ++round) {
    float v[8];
    for (float& x : v) x = value(rng);  // the saddles' answers vary too
    const CellCase& cc = cell_case(v);
    for (int L = 0; L < cc.loops; ++L) {
      if (cc.triangles[L] < 2) continue;
      const CellLoop loop(cc, L, rng, round % 4 == 1, round % 4 == 3);
      const bool by_view = loop_embedded(cc, L, loop.pts, loop.lo, loop.hi);
      const bool pairs = loop.no_pair_crosses();
      ++loops;
      proved += by_view;
      crossing += !pairs;
      // A proof is never wrong.
      if (by_view) ASSERT_TRUE(pairs) << "round " << round << " loop " << L;
      // A point at an end of its edge is not proved (it may coincide with a corner's point).
      if (round % 4 == 3) EXPECT_FALSE(by_view) << "round " << round;
      // Points strictly inside their edges are proved whenever no order within a side is needed.
      if (round % 4 == 0 || round % 4 == 2) {
        if (cc.view_axis[L] < 3 && cc.view_orders[L] == 0)
          EXPECT_TRUE(by_view) << "round " << round;
        unordered += cc.view_orders[L] > 0 && !by_view;
      }
    }
  }
  // Most loops are proved; some of the others do cross (so the proof had cases to refuse), and
  // the orders within a side fail for some random places.
  EXPECT_GT(proved, loops / 2);
  EXPECT_GT(crossing, 10);
  EXPECT_GT(unordered, 10);
}

TEST(Embed, APointOffItsEdgeOrOffTheCellIsNotProved) {
  float v[8] = {-1, 1, 1, 1, -1, 1, 1, 1};  // corners 0 and 4 inside: a quad round the z edge
  const CellCase& cc = cell_case(v);
  ASSERT_EQ(cc.loops, 1);
  ASSERT_EQ(cc.triangles[0], 2);
  std::mt19937_64 rng(7);
  const CellLoop loop(cc, 0, rng, false, false);
  ASSERT_TRUE(loop_embedded(cc, 0, loop.pts, loop.lo, loop.hi));
  const CubeTables& ct = cube();
  for (int q = 0; q < cc.length[0]; ++q) {
    const int j = ct.edge_axis[cc.edge[0][q]];
    for (int a = 0; a < 3; ++a) {
      P moved[12];
      std::copy(loop.pts, loop.pts + 12, moved);
      // One unit in the last place off its edge's line, or onto the cell's wall.
      moved[q][a] = a == j ? loop.hi[a] : std::nextafter(moved[q][a], 2.0);
      EXPECT_FALSE(loop_embedded(cc, 0, moved, loop.lo, loop.hi)) << q << " " << a;
    }
  }
}

}  // namespace
}  // namespace qjulia::detail
