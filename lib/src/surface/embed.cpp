#include "surface/embed.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/intersections.h>

#include <algorithm>

namespace qjulia::detail {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;

Point point(const std::array<double, 3>& p) { return Point(p[0], p[1], p[2]); }

// True when the bounding boxes of the points a[0..na) and b[0..nb) are disjoint: then nothing
// of the one meets the other (an exact test, made before the predicates).
bool boxes_apart(const std::array<double, 3>* a, int na, const std::array<double, 3>* b, int nb) {
  for (int k = 0; k < 3; ++k) {
    double alo = a[0][k], ahi = a[0][k], blo = b[0][k], bhi = b[0][k];
    for (int i = 1; i < na; ++i) {
      alo = std::min(alo, a[i][k]);
      ahi = std::max(ahi, a[i][k]);
    }
    for (int i = 1; i < nb; ++i) {
      blo = std::min(blo, b[i][k]);
      bhi = std::max(bhi, b[i][k]);
    }
    if (ahi < blo || bhi < alo) return true;
  }
  return false;
}

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
  if (shared == 1) {
    // A shared corner: they cross when the edge opposite it in one meets the other.
    int i = 0;
    while (at[i] < 0) ++i;
    const int j = at[i];
    const std::array<double, 3> ea[2] = {a[(i + 1) % 3], a[(i + 2) % 3]};
    const std::array<double, 3> eb[2] = {b[(j + 1) % 3], b[(j + 2) % 3]};
    const bool b_edge_apart = boxes_apart(a.data(), 3, eb, 2);
    const bool a_edge_apart = boxes_apart(b.data(), 3, ea, 2);
    if (b_edge_apart && a_edge_apart) return false;
    const K::Triangle_3 ta(pa[0], pa[1], pa[2]), tb(pb[0], pb[1], pb[2]);
    const K::Segment_3 sa(pa[(i + 1) % 3], pa[(i + 2) % 3]), sb(pb[(j + 1) % 3], pb[(j + 2) % 3]);
    return (!b_edge_apart && CGAL::do_intersect(ta, sb)) ||
           (!a_edge_apart && CGAL::do_intersect(tb, sa));
  }
  if (boxes_apart(a.data(), 3, b.data(), 3)) return false;
  const K::Triangle_3 ta(pa[0], pa[1], pa[2]), tb(pb[0], pb[1], pb[2]);
  return CGAL::do_intersect(ta, tb);
}

}  // namespace qjulia::detail
