#include "surface/embed.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/intersections.h>

namespace qjulia::detail {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;

Point point(const std::array<double, 3>& p) { return Point(p[0], p[1], p[2]); }

}  // namespace

bool triangles_cross(const Triangle& a, const Triangle& b) {
  const Point pa[3] = {point(a[0]), point(a[1]), point(a[2])};
  const Point pb[3] = {point(b[0]), point(b[1]), point(b[2])};
  // Corners in common: a's corner i is b's corner at[i], or -1.
  int at[3] = {-1, -1, -1}, shared = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (a[i] == b[j]) {
        at[i] = j;
        ++shared;
      }
  if (shared >= 3) return true;  // the same triangle twice
  if (shared == 2) {
    // A shared edge (u, v): the triangles overlap only when they lie in one plane with their
    // third corners on the same side of it.
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
    // A shared corner: they cross when the edge opposite it in one meets the other.
    int i = 0;
    while (at[i] < 0) ++i;
    const int j = at[i];
    const K::Segment_3 sa(pa[(i + 1) % 3], pa[(i + 2) % 3]), sb(pb[(j + 1) % 3], pb[(j + 2) % 3]);
    return CGAL::do_intersect(ta, sb) || CGAL::do_intersect(tb, sa);
  }
  return CGAL::do_intersect(ta, tb);
}

}  // namespace qjulia::detail
