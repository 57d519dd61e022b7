#pragma once
/// @file quaternion.h
/// A quaternion value type q = w + x i + y j + z k with the Hamilton product.
#include <cmath>

namespace qjulia {

/// A quaternion w + x i + y j + z k in double precision. Plain value type.
struct Quat {
  double w = 0, x = 0, y = 0, z = 0;

  constexpr Quat() = default;
  constexpr Quat(double w_, double x_, double y_, double z_) : w(w_), x(x_), y(y_), z(z_) {}
  /// A real quaternion.
  constexpr explicit Quat(double r) : w(r) {}

  constexpr double operator[](int i) const { return i == 0 ? w : i == 1 ? x : i == 2 ? y : z; }
};

constexpr Quat operator+(const Quat& a, const Quat& b) {
  return {a.w + b.w, a.x + b.x, a.y + b.y, a.z + b.z};
}
constexpr Quat operator-(const Quat& a, const Quat& b) {
  return {a.w - b.w, a.x - b.x, a.y - b.y, a.z - b.z};
}
constexpr Quat operator-(const Quat& a) { return {-a.w, -a.x, -a.y, -a.z}; }
constexpr Quat operator*(double s, const Quat& a) { return {s * a.w, s * a.x, s * a.y, s * a.z}; }
constexpr Quat operator*(const Quat& a, double s) { return s * a; }

/// Hamilton product; not commutative.
constexpr Quat operator*(const Quat& a, const Quat& b) {
  return {
      a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z, a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
      a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x, a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
}

/// Squared norm |q|^2.
constexpr double norm2(const Quat& a) { return a.w * a.w + a.x * a.x + a.y * a.y + a.z * a.z; }
/// Euclidean norm |q|.
inline double abs(const Quat& a) { return std::sqrt(norm2(a)); }
/// Conjugate w - x i - y j - z k.
constexpr Quat conj(const Quat& a) { return {a.w, -a.x, -a.y, -a.z}; }
/// Inverse conj(q)/|q|^2; a zero quaternion gives non-finite components (a pole).
constexpr Quat inv(const Quat& a) {
  const double n = norm2(a);
  return {a.w / n, -a.x / n, -a.y / n, -a.z / n};
}
/// Square, cheaper than a*a: (w^2 - |v|^2, 2 w v).
constexpr Quat sqr(const Quat& a) {
  return {a.w * a.w - a.x * a.x - a.y * a.y - a.z * a.z, 2 * a.w * a.x, 2 * a.w * a.y,
          2 * a.w * a.z};
}
/// Right division a * b^-1, the meaning of a/b in formulas.
constexpr Quat operator/(const Quat& a, const Quat& b) { return a * inv(b); }
/// True when every component is finite.
inline bool is_finite(const Quat& a) {
  return std::isfinite(a.w) && std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z);
}

}  // namespace qjulia
