#include "surface/refine.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace qjulia::detail {
namespace {

std::array<double, 3> lerp(const std::array<double, 3>& a, const std::array<double, 3>& b,
                           double t) {
  return {a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])};
}

// One segment in refinement; the states of the points being evaluated are kept in the order
// of their evaluation (compacted as segments finish), so that each step reads them in turn.
struct State {
  double lo = 0, hi = 1;    // lo keeps the sign of a, hi the sign of b
  double glo = 0, ghi = 0;  // the refinement values there, when known
  double t = 0;             // the point being evaluated
  std::uint32_t seg = 0;    // its segment
  bool lo_known = false, hi_known = false;
  bool plane = false;  // the outside end is outside only because of the box or a clip plane
  bool a_inside = false;  // the segment's end a is in the solid
  std::int8_t side = 0;   // Illinois: which end was kept last (-1 lo, +1 hi)
  std::int32_t steps = 0;
};

// Values of the refinement function beyond this are "far" (an orbit decided early), not a
// smooth value to interpolate.
constexpr float kFar = 1e5f;

}  // namespace

std::uint64_t refine_segments(const Solid& solid, const Segment* seg, std::size_t n, double tol_t,
                              int max_steps, std::array<double, 3>* out) {
  thread_local std::vector<State> st;
  thread_local std::vector<double> x, y, z;
  thread_local std::vector<float> f;
  st.resize(n);
  x.resize(n);
  y.resize(n);
  z.resize(n);
  f.resize(n);
  // Point q of the next evaluation: state s at its t.
  auto place = [&](std::size_t q, const State& s) {
    const auto p = lerp(seg[s.seg].a, seg[s.seg].b, s.t);
    x[q] = p[0];
    y[q] = p[1];
    z[q] = p[2];
  };
  // An end outside only because of the box or a clip plane: the boundary is the plane when the
  // point on it is in the solid, which makes caps exactly flat. Else the first guess: where the
  // grid values interpolate to zero.
  for (std::size_t i = 0; i < n; ++i) {
    State s;
    s.seg = static_cast<std::uint32_t>(i);
    s.a_inside = seg[i].fa <= 0;
    // An end in the solid has the refinement value of its field (the two agree inside).
    s.glo = seg[i].fa;
    s.ghi = seg[i].fb;
    s.lo_known = s.a_inside;
    s.hi_known = !s.a_inside;
    const auto& o = s.a_inside ? seg[i].b : seg[i].a;
    s.plane = solid.constraint(o[0], o[1], o[2]) > 0;
    if (s.plane) {
      const double c = solid.constraint_crossing(s.a_inside ? seg[i].a : seg[i].b, o);
      const double tc = s.a_inside ? c : 1 - c;
      s.t = std::clamp(tc, kEndMargin, 1 - kEndMargin);
    } else {
      double t = seg[i].fa / (seg[i].fa - seg[i].fb);
      if (!(t > 0.01 && t < 0.99)) t = std::clamp(t, 0.01, 0.99);
      s.t = t;
    }
    st[i] = s;
    place(i, s);
  }
  // Then regula falsi on the refinement values with the Illinois rule (the end kept twice has
  // its value halved, so both ends close in), bisection while an end's value is unknown or far.
  // Each step evaluates the points, moves each segment's bracket, and either places the
  // segment's vertex or queues its next point (in the same order).
  std::uint64_t evaluations = 0;
  std::size_t queued = n;
  for (bool first = true; queued > 0; first = false) {
    solid.root_field(x.data(), y.data(), z.data(), queued, f.data());
    evaluations += queued;
    std::size_t next = 0;
    for (std::size_t q = 0; q < queued; ++q) {
      State s = st[q];
      const Segment& sg = seg[s.seg];
      if (first && s.plane && f[q] <= 0) {
        out[s.seg] = lerp(sg.a, sg.b, s.t);
        continue;
      }
      ++s.steps;
      if ((f[q] <= 0) == s.a_inside) {
        s.lo = s.t;
        s.glo = f[q];
        s.lo_known = true;
        if (s.side == -1) s.ghi *= 0.5f;  // hi kept twice (never on the first step)
        if (!first) s.side = -1;
      } else {
        s.hi = s.t;
        s.ghi = f[q];
        s.hi_known = true;
        if (s.side == 1) s.glo *= 0.5f;
        if (!first) s.side = 1;
      }
      const bool smooth = s.lo_known && s.hi_known && std::abs(s.glo) < kFar &&
                          std::abs(s.ghi) < kFar && s.glo != s.ghi;
      double t = smooth ? (s.glo * s.hi - s.ghi * s.lo) / (s.glo - s.ghi) : 0.5 * (s.lo + s.hi);
      if (s.steps >= max_steps || !(s.hi - s.lo > tol_t)) {
        if (!(t >= s.lo && t <= s.hi)) t = 0.5 * (s.lo + s.hi);
        // Never on a grid point: a vertex there would coincide with the vertices of the other
        // edges of that point and leave zero-area triangles.
        out[s.seg] = lerp(sg.a, sg.b, std::clamp(t, kEndMargin, 1 - kEndMargin));
        continue;
      }
      const double margin = 0.01 * (s.hi - s.lo);
      if (!(t > s.lo + margin && t < s.hi - margin))
        t = std::clamp(t, s.lo + margin, s.hi - margin);
      s.t = t;
      st[next] = s;
      place(next, s);
      ++next;
    }
    queued = next;
  }
  return evaluations;
}

std::array<double, 3> boundary_in_cell(const Solid& solid, const std::array<double, 3>& c,
                                       const std::array<double, 3>& normal,
                                       const std::array<double, 3>& lo, double voxel, double tol_t,
                                       std::uint64_t* evaluations) {
  std::array<double, 3> dirs[14];
  dirs[0] = normal;
  int nd = 1;
  for (int dx = -1; dx <= 1; ++dx)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dz = -1; dz <= 1; ++dz)
        if (dx > 0 || (dx == 0 && (dy > 0 || (dy == 0 && dz > 0))))
          dirs[nd++] = {double(dx), double(dy), double(dz)};
  // Half-lines from c both ways along each direction, to the cell's walls less the margin.
  const double margin = 1e-3 * voxel;
  std::vector<std::array<double, 3>> ends;
  for (const auto& dir : dirs) {
    if (!(dir[0] != 0 || dir[1] != 0 || dir[2] != 0)) continue;
    for (double sign : {-1.0, 1.0}) {
      double t = std::numeric_limits<double>::infinity();
      for (int k = 0; k < 3; ++k) {
        const double u = sign * dir[k];
        if (u > 0) t = std::min(t, (lo[k] + voxel - margin - c[k]) / u);
        if (u < 0) t = std::min(t, (lo[k] + margin - c[k]) / u);
      }
      if (!(t > 0) || !std::isfinite(t)) continue;
      ends.push_back(
          {c[0] + t * sign * dir[0], c[1] + t * sign * dir[1], c[2] + t * sign * dir[2]});
    }
  }
  std::vector<double> x(ends.size() + 1), y(ends.size() + 1), z(ends.size() + 1);
  std::vector<float> f(ends.size() + 1);
  x[0] = c[0];
  y[0] = c[1];
  z[0] = c[2];
  for (std::size_t i = 0; i < ends.size(); ++i) {
    x[i + 1] = ends[i][0];
    y[i + 1] = ends[i][1];
    z[i + 1] = ends[i][2];
  }
  solid.field(x.data(), y.data(), z.data(), x.size(), f.data());
  *evaluations += x.size();
  std::vector<Segment> segs;
  for (std::size_t i = 0; i < ends.size(); ++i) {
    if ((f[0] <= 0) == (f[i + 1] <= 0)) continue;
    Segment s;
    s.a = c;
    s.fa = f[0];
    s.b = ends[i];
    s.fb = f[i + 1];
    segs.push_back(s);
  }
  if (segs.empty()) return c;
  std::vector<std::array<double, 3>> found(segs.size());
  *evaluations += refine_segments(solid, segs.data(), segs.size(), tol_t, 24, found.data());
  std::array<double, 3> best_point = c;
  double best = std::numeric_limits<double>::infinity();
  for (const auto& p : found) {
    const double dist = std::hypot(p[0] - c[0], p[1] - c[1], p[2] - c[2]);
    if (dist < best) {
      best = dist;
      best_point = p;
    }
  }
  return best_point;
}

}  // namespace qjulia::detail
