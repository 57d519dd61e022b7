#include "surface/embed.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/intersections.h>

#include <algorithm>
#include <cmath>

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

// The sign of the orientation of (pa, pb, pc, pd) (that of the determinant of pa - pd, pb - pd,
// pc - pd) when floating point certifies it, else 0: Shewchuk's first stage (orient3d), whose
// error bound covers every rounding of the differences and products in this order (no
// contraction into fused multiply-adds: ISO C++ mode), taken twice for margin.
int certain_orientation(const std::array<double, 3>& pa, const std::array<double, 3>& pb,
                        const std::array<double, 3>& pc, const std::array<double, 3>& pd) {
  const double adx = pa[0] - pd[0], bdx = pb[0] - pd[0], cdx = pc[0] - pd[0];
  const double ady = pa[1] - pd[1], bdy = pb[1] - pd[1], cdy = pc[1] - pd[1];
  const double adz = pa[2] - pd[2], bdz = pb[2] - pd[2], cdz = pc[2] - pd[2];
  const double bdxcdy = bdx * cdy, cdxbdy = cdx * bdy;
  const double cdxady = cdx * ady, adxcdy = adx * cdy;
  const double adxbdy = adx * bdy, bdxady = bdx * ady;
  const double det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady);
  const double permanent = (std::abs(bdxcdy) + std::abs(cdxbdy)) * std::abs(adz) +
                           (std::abs(cdxady) + std::abs(adxcdy)) * std::abs(bdz) +
                           (std::abs(adxbdy) + std::abs(bdxady)) * std::abs(cdz);
  constexpr double kEpsilon = 0x1p-53;
  constexpr double kBound = 2 * (7.0 + 56.0 * kEpsilon) * kEpsilon;
  const double bound = kBound * permanent;
  return det > bound ? 1 : det < -bound ? -1 : 0;
}

// True when points p[0..n) lie strictly on one side of the plane of triangle t, certified.
bool certainly_beside(const Triangle& t, const std::array<double, 3>* p, int n) {
  const int first = certain_orientation(t[0], t[1], t[2], p[0]);
  if (first == 0) return false;
  for (int k = 1; k < n; ++k)
    if (certain_orientation(t[0], t[1], t[2], p[k]) != first) return false;
  return true;
}

}  // namespace

bool triangles_cross(const Triangle& a, const Triangle& b) {
  // Corners in common: a's corner i is b's corner at[i], or -1.
  int at[3] = {-1, -1, -1}, shared = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (a[i] == b[j]) {
        at[i] = j;
        ++shared;
      }
  if (shared >= 3) return true;  // the same triangle twice
  // Before the exact predicates, what floating point certifies: corners not in one plane, an
  // edge strictly on one side of the other triangle's plane.
  if (shared == 2) {
    // A shared edge (u, v): the triangles overlap only when they lie in one plane with their
    // third corners on the same side of it.
    int p = 0;
    while (at[p] >= 0) ++p;
    int q = 0;
    while (q == at[(p + 1) % 3] || q == at[(p + 2) % 3]) ++q;
    if (certain_orientation(a[(p + 1) % 3], a[(p + 2) % 3], a[p], b[q]) != 0) return false;
    const Point u = point(a[(p + 1) % 3]), v = point(a[(p + 2) % 3]);
    const Point ap = point(a[p]), bq = point(b[q]);
    return CGAL::coplanar(u, v, ap, bq) &&
           CGAL::coplanar_orientation(u, v, ap, bq) == CGAL::POSITIVE;
  }
  if (shared == 1) {
    // A shared corner: they cross when the edge opposite it in one meets the other.
    int i = 0;
    while (at[i] < 0) ++i;
    const int j = at[i];
    const std::array<double, 3> ea[2] = {a[(i + 1) % 3], a[(i + 2) % 3]};
    const std::array<double, 3> eb[2] = {b[(j + 1) % 3], b[(j + 2) % 3]};
    const bool b_edge_apart = boxes_apart(a.data(), 3, eb, 2) || certainly_beside(a, eb, 2);
    const bool a_edge_apart = boxes_apart(b.data(), 3, ea, 2) || certainly_beside(b, ea, 2);
    if (b_edge_apart && a_edge_apart) return false;
    const Point pa[3] = {point(a[0]), point(a[1]), point(a[2])};
    const Point pb[3] = {point(b[0]), point(b[1]), point(b[2])};
    const K::Triangle_3 ta(pa[0], pa[1], pa[2]), tb(pb[0], pb[1], pb[2]);
    const K::Segment_3 sa(pa[(i + 1) % 3], pa[(i + 2) % 3]), sb(pb[(j + 1) % 3], pb[(j + 2) % 3]);
    return (!b_edge_apart && CGAL::do_intersect(ta, sb)) ||
           (!a_edge_apart && CGAL::do_intersect(tb, sa));
  }
  if (boxes_apart(a.data(), 3, b.data(), 3)) return false;
  if (certainly_beside(a, b.data(), 3) || certainly_beside(b, a.data(), 3)) return false;
  const K::Triangle_3 ta(point(a[0]), point(a[1]), point(a[2]));
  const K::Triangle_3 tb(point(b[0]), point(b[1]), point(b[2]));
  return CGAL::do_intersect(ta, tb);
}

}  // namespace qjulia::detail
