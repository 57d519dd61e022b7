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

}  // namespace
}  // namespace qjulia::detail
