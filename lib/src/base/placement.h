#pragma once
/// @file placement.h
/// Affine placements of the mesh readers that place parts (glTF's nodes, 3MF's build items and
/// components): composing them, moving positions and normals, and keeping a mirror's faces
/// outward. Header-only: the 3MF module must not link the library.
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <utility>

namespace qjulia::detail {

/// An affine placement, p' = m (p, 1): three rows of four, row-major (lib3mf's MODELTRANSFORM
/// layout; glTF's column-major 4x4 is its transpose, the last row left out).
using Placement = std::array<double, 12>;

inline constexpr Placement kUnmoved = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};

/// `outer` after `inner`: p -> outer(inner(p)).
inline Placement compose(const Placement& outer, const Placement& inner) {
  Placement m{};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) {
      double v = c == 3 ? outer[r * 4 + 3] : 0.0;
      for (int k = 0; k < 3; ++k) v += outer[r * 4 + k] * inner[k * 4 + c];
      m[r * 4 + c] = v;
    }
  }
  return m;
}

/// The determinant of the linear part: negative for a mirroring placement.
inline double determinant(const Placement& m) {
  return m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) +
         m[2] * (m[4] * m[9] - m[5] * m[8]);
}

/// Moves the `n` positions at `p` by `m`.
inline void place_positions(const Placement& m, std::array<float, 3>* p, std::size_t n) {
  for (std::size_t v = 0; v < n; ++v) {
    const std::array<float, 3> q = p[v];
    for (int r = 0; r < 3; ++r)
      p[v][r] = static_cast<float>(m[r * 4] * q[0] + m[r * 4 + 1] * q[1] + m[r * 4 + 2] * q[2] +
                                   m[r * 4 + 3]);
  }
}

/// Turns the `n` normals at `normal` by `m`: the inverse transpose of its linear part (its
/// cofactors, the sign of the determinant kept), each of unit length again (0 stays 0).
inline void place_normals(const Placement& m, std::array<float, 3>* normal, std::size_t n) {
  const double c[9] = {
      m[5] * m[10] - m[6] * m[9], m[6] * m[8] - m[4] * m[10], m[4] * m[9] - m[5] * m[8],
      m[2] * m[9] - m[1] * m[10], m[0] * m[10] - m[2] * m[8], m[1] * m[8] - m[0] * m[9],
      m[1] * m[6] - m[2] * m[5],  m[2] * m[4] - m[0] * m[6],  m[0] * m[5] - m[1] * m[4]};
  const double sign = determinant(m) < 0 ? -1.0 : 1.0;
  for (std::size_t v = 0; v < n; ++v) {
    const std::array<float, 3> a = normal[v];
    double q[3];
    for (int r = 0; r < 3; ++r) q[r] = c[r * 3] * a[0] + c[r * 3 + 1] * a[1] + c[r * 3 + 2] * a[2];
    const double len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
    const double k = len > 0 ? sign / len : 0.0;
    normal[v] = {static_cast<float>(q[0] * k), static_cast<float>(q[1] * k),
                 static_cast<float>(q[2] * k)};
  }
}

/// Keeps the `n` triangles at `t` facing outward after `m`: a mirror turns them inside out, so
/// their winding is reversed.
inline void keep_outward(const Placement& m, std::array<std::uint32_t, 3>* t, std::size_t n) {
  if (determinant(m) >= 0) return;
  for (std::size_t f = 0; f < n; ++f) std::swap(t[f][1], t[f][2]);
}

}  // namespace qjulia::detail
