#pragma once
/// @file geometry.h
/// The geometry kernel every stage shares: double-precision vector helpers (the renderer's too),
/// triangle area and signed volume, area-weighted normals, and the one point-to-triangle
/// distance (used by the BVH, so by compare and by decimate's error measurement).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

namespace qjulia::detail {

/// A point or vector in double precision (its operators are found by argument-dependent lookup).
struct Vec3d {
  double v[3];
  double operator[](int k) const { return v[k]; }
  double& operator[](int k) { return v[k]; }
};

template <class T>
Vec3d to_vec3d(const std::array<T, 3>& p) {
  return {double(p[0]), double(p[1]), double(p[2])};
}
inline Vec3d operator+(const Vec3d& a, const Vec3d& b) {
  return {a[0] + b[0], a[1] + b[1], a[2] + b[2]};
}
inline Vec3d operator-(const Vec3d& a, const Vec3d& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
inline Vec3d operator-(const Vec3d& a) { return {-a[0], -a[1], -a[2]}; }
inline Vec3d operator*(double s, const Vec3d& a) { return {s * a[0], s * a[1], s * a[2]}; }
inline double dot(const Vec3d& a, const Vec3d& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
inline Vec3d cross(const Vec3d& a, const Vec3d& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline double length(const Vec3d& a) { return std::sqrt(dot(a, a)); }
/// `a` divided by its length; (0, 0, 0) when it has none.
inline Vec3d normalized(const Vec3d& a) {
  const double n = length(a);
  return n > 0 ? Vec3d{a[0] / n, a[1] / n, a[2] / n} : Vec3d{0, 0, 0};
}

/// Area of the triangle abc.
inline double triangle_area(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  return 0.5 * length(cross(b - a, c - a));
}

/// Signed volume of the tetrahedron (origin, a, b, c): summed over a closed outward mesh it is
/// the enclosed volume (divergence theorem). Pass corners relative to a point near the mesh for
/// precision.
inline double tetra_volume(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  return dot(a, cross(b, c)) / 6.0;
}

/// Triangle t's area-weighted normal (|n| = 2 * area), rounded to float: what
/// add_area_normals() adds at each of its corners. `position(v)` gives corner v.
template <class Triangle, class PositionOf>
std::array<float, 3> area_normal(const Triangle& t, const PositionOf& position) {
  const Vec3d a = to_vec3d(position(t[0]));
  const Vec3d n = cross(to_vec3d(position(t[1])) - a, to_vec3d(position(t[2])) - a);
  return {static_cast<float>(n[0]), static_cast<float>(n[1]), static_cast<float>(n[2])};
}

/// Adds each triangle's area-weighted normal (|n| = 2 * area) to its corners' float sums, in
/// triangle order: `position(v)` gives corner v, `sum(v)` its sum or null (not summed here; a
/// triangle with no corner summed is skipped). One process and the ranks of a distributed run,
/// and the threads of area_weighted_normals(), add in this same order, so they agree bit for bit.
template <class Triangles, class PositionOf, class SumOf>
void add_area_normals(const Triangles& triangles, const PositionOf& position, const SumOf& sum) {
  for (const auto& t : triangles) {
    std::array<float, 3>* const s[3] = {sum(t[0]), sum(t[1]), sum(t[2])};
    if (!s[0] && !s[1] && !s[2]) continue;
    const std::array<float, 3> n = area_normal(t, position);
    for (std::array<float, 3>* c : s)
      if (c)
        for (int k = 0; k < 3; ++k) (*c)[k] += n[k];
  }
}

/// A sum of add_area_normals() made unit length; (0, 0, 1) where it has no direction.
inline void normalize_sum(std::array<float, 3>& n) {
  const double len = std::sqrt(double(n[0]) * n[0] + double(n[1]) * n[1] + double(n[2]) * n[2]);
  if (len > 0 && std::isfinite(len))
    n = {float(n[0] / len), float(n[1] / len), float(n[2] / len)};
  else
    n = {0, 0, 1};
}

/// The Morton code of a grid cell: the low 21 bits of x, y and z interleaved (x in bit 0). Cells
/// close in space are mostly close along the curve.
inline uint64_t morton_code(uint32_t x, uint32_t y, uint32_t z) {
  auto spread = [](uint64_t v) {
    v &= 0x1fffff;
    v = (v | v << 32) & 0x1f00000000ffffULL;
    v = (v | v << 16) & 0x1f0000ff0000ffULL;
    v = (v | v << 8) & 0x100f00f00f00f00fULL;
    v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
    v = (v | v << 2) & 0x1249249249249249ULL;
    return v;
  };
  return spread(x) | spread(y) << 1 | spread(z) << 2;
}

/// Squared distance from p to the triangle (a, a + ab, a + ac), in float (Ericson, Real-Time
/// Collision Detection, 5.1.5: Voronoi regions of the vertices and edges, else the face). A
/// degenerate triangle gives the distance to the nearest of its edges.
/// Inline: it is the inner loop of every closest-point query.
inline float point_triangle_distance_sq(const float p[3], const float a[3], const float ab[3],
                                        const float ac[3]) {
  auto dot3 = [](const float u[3], const float v[3]) {
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
  };
  const float ap[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]};
  const float d1 = dot3(ab, ap), d2 = dot3(ac, ap);
  auto dist_to = [&](float s, float t) {  // |a + s ab + t ac - p|^2
    float d = 0;
    for (int k = 0; k < 3; ++k) {
      const float e = s * ab[k] + t * ac[k] - ap[k];
      d += e * e;
    }
    return d;
  };
  if (d1 <= 0 && d2 <= 0) return dot3(ap, ap);  // vertex a
  const float bp[3] = {ap[0] - ab[0], ap[1] - ab[1], ap[2] - ab[2]};
  const float d3 = dot3(ab, bp), d4 = dot3(ac, bp);
  if (d3 >= 0 && d4 <= d3) return dot3(bp, bp);  // vertex b
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return dist_to(d1 / (d1 - d3), 0);  // edge ab
  const float cp[3] = {ap[0] - ac[0], ap[1] - ac[1], ap[2] - ac[2]};
  const float d5 = dot3(ab, cp), d6 = dot3(ac, cp);
  if (d6 >= 0 && d5 <= d6) return dot3(cp, cp);  // vertex c
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return dist_to(0, d2 / (d2 - d6));  // edge ac
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {  // edge bc
    const float w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return dist_to(1 - w, w);
  }
  const float sum = va + vb + vc;
  if (!(sum > 0)) {  // a degenerate triangle: the closest of its three edges
    auto seg = [&](const float o[3], const float dir[3]) {
      const float len = dot3(dir, dir);
      const float q[3] = {p[0] - o[0], p[1] - o[1], p[2] - o[2]};
      const float t = len > 0 ? std::clamp(dot3(q, dir) / len, 0.0f, 1.0f) : 0.0f;
      float d = 0;
      for (int k = 0; k < 3; ++k) {
        const float e = q[k] - t * dir[k];
        d += e * e;
      }
      return d;
    };
    const float b[3] = {a[0] + ab[0], a[1] + ab[1], a[2] + ab[2]};
    const float bc[3] = {ac[0] - ab[0], ac[1] - ab[1], ac[2] - ab[2]};
    return std::min({seg(a, ab), seg(a, ac), seg(b, bc)});
  }
  const float denom = 1.0f / sum;
  return std::max(dist_to(vb * denom, vc * denom), 0.0f);  // inside the face
}

}  // namespace qjulia::detail
