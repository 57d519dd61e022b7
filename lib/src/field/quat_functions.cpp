// The analytic functions of quat_functions.h. Each one finds the plane of q (a, t = |v|,
// u = v/t), evaluates the complex function at a + t i with real arithmetic, and maps the
// imaginary part back onto u. Sums of squares are formed directly when they can neither
// overflow nor lose bits to underflow, and after an exact scaling by a power of two otherwise.
#include "field/quat_functions.h"

#include <algorithm>
#include <cmath>

namespace qjulia {
namespace detail {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kLn2 = 0.69314718055994530942;
// A sum of squares in [kSmall, kLarge] lost nothing to underflow (subnormal squares are off by
// at most 2^-1075, far below its ulp) and did not overflow; its square root is normal.
constexpr double kSmall = 1e-290;
constexpr double kLarge = 1e290;

bool in_range(double s) { return s >= kSmall && s <= kLarge; }

/// The plane of q = a + v: t = |v|, u = v/t (u = i when t = 0), and s = |v|^2 when it is in
/// range (0 otherwise, and then not used).
struct Plane {
  double a, t, s;
  double ux, uy, uz;
};

Plane plane_of(const Quat& q) {
  Plane p;
  p.a = q.w;
  p.s = q.x * q.x + q.y * q.y + q.z * q.z;
  if (in_range(p.s)) {
    p.t = std::sqrt(p.s);
    const double r = 1 / p.t;
    p.ux = q.x * r;
    p.uy = q.y * r;
    p.uz = q.z * r;
    return p;
  }
  p.s = 0;
  const double m = std::max({std::abs(q.x), std::abs(q.y), std::abs(q.z)});
  if (m == 0) {
    p.t = 0;
    p.ux = 1;
    p.uy = p.uz = 0;
    return p;
  }
  if (!std::isfinite(m)) {  // non-finite in, non-finite out
    p.t = m;
    p.ux = q.x;
    p.uy = q.y;
    p.uz = q.z;
    return p;
  }
  // Exact scaling so that the largest component lies in [1, 2).
  const int e = std::ilogb(m);
  const double x = std::scalbn(q.x, -e), y = std::scalbn(q.y, -e), z = std::scalbn(q.z, -e);
  const double r = std::sqrt(x * x + y * y + z * z);
  p.t = std::scalbn(r, e);
  p.ux = x / r;
  p.uy = y / r;
  p.uz = z / r;
  return p;
}

/// X + Y u.
Quat on_plane(const Plane& p, double re, double im) {
  return {re, im * p.ux, im * p.uy, im * p.uz};
}

/// t^2 (exactly |v|^2 as summed when that is in range).
double t2(const Plane& p) { return p.s != 0 ? p.s : p.t * p.t; }

/// |q|^2 = a^2 + t^2 when it is in range, else 0 (then the caller scales q).
double norm2_in_range(const Plane& p) {
  const double n2 = p.a * p.a + t2(p);
  return in_range(n2) ? n2 : 0;
}

/// The exponent e that brings the largest component of a finite, non-zero q into [1, 2) by
/// q * 2^-e; 0 for a zero or non-finite q (scaling cannot help those).
int scale_exponent(const Quat& q) {
  const double m = std::max({std::abs(q.w), std::abs(q.x), std::abs(q.y), std::abs(q.z)});
  return m > 0 && std::isfinite(m) ? std::ilogb(m) : 0;
}

Quat scaled(const Quat& q, int e) {
  return {std::scalbn(q.w, e), std::scalbn(q.x, e), std::scalbn(q.y, e), std::scalbn(q.z, e)};
}

/// cosh x and sinh x for x >= 0 from one exponential, without the cancellation of
/// (e^x - e^-x)/2 near 0 and finite up to x = 710.47 like std::cosh.
void cosh_sinh(double x, double* ch, double* sh) {
  if (x < 22) {  // below 22, e^-x is not lost in e^x
    const double em = std::expm1(x);
    const double e = 1 + em;
    *sh = 0.5 * (em + em / e);  // e - 1/e = em + em/e, a sum of like signs
    *ch = 0.5 * (e + 1 / e);
  } else if (x < 709) {
    *ch = *sh = 0.5 * std::exp(x);
  } else {
    const double half = std::exp(0.5 * x);
    *ch = *sh = (0.5 * half) * half;
  }
}

/// cosh x and sinh x for any real x.
void cosh_sinh_signed(double x, double* ch, double* sh) {
  cosh_sinh(std::abs(x), ch, sh);
  *sh = std::copysign(*sh, x);
}

/// The complex tanh(x + i y) = re + i im by Kahan's formula, accurate near the poles and free
/// of overflow ("Branch cuts for complex elementary functions", 1987).
void complex_tanh(double x, double y, double* re, double* im) {
  if (std::abs(x) > 22) {  // tanh x rounds to +-1; the imaginary part decays like e^-2|x|
    *re = std::copysign(1.0, x);
    *im = 4 * std::sin(y) * std::cos(y) * std::exp(-2 * std::abs(x));
    return;
  }
  const double tn = std::tan(y);
  const double beta = 1 + tn * tn;  // 1 / cos^2 y
  double ch, sh;
  cosh_sinh_signed(x, &ch, &sh);
  const double d = 1 + beta * sh * sh;
  *re = beta * ch * sh / d;
  *im = tn / d;
}

/// log|q| for q in the plane p.
double log_abs(const Quat& q, const Plane& p) {
  const double n2 = norm2_in_range(p);
  if (n2 != 0) {
    // Near |q| = 1 the real part carries the information: log1p of a^2 - 1 + |v|^2 with
    // a^2 - 1 rounded once.
    if (n2 > 0.5 && n2 < 2) return 0.5 * std::log1p(std::fma(p.a, p.a, -1) + t2(p));
    return 0.5 * std::log(n2);
  }
  if (q.w == 0 && p.t == 0) return -HUGE_VAL;  // log 0: a pole
  const int e = scale_exponent(q);
  return 0.5 * std::log(norm2(scaled(q, -e))) + e * kLn2;
}

/// cosh(q) and sinh(q) together: cosh a cos t + u sinh a sin t and sinh a cos t + u cosh a sin t.
void quat_cosh_sinh(const Quat& q, Quat* ch, Quat* sh) {
  const Plane p = plane_of(q);
  double cha, sha;
  cosh_sinh_signed(p.a, &cha, &sha);
  if (p.t == 0) {  // real: no 0 * inf in the vector part
    *ch = Quat(cha);
    *sh = Quat(sha);
    return;
  }
  const double c = std::cos(p.t), s = std::sin(p.t);
  *ch = on_plane(p, cha * c, sha * s);
  *sh = on_plane(p, sha * c, cha * s);
}

}  // namespace

Quat qexp(const Quat& q) {
  const Plane p = plane_of(q);
  if (p.t == 0) return Quat(std::exp(p.a));
  const double c = std::cos(p.t), s = std::sin(p.t);
  if (p.a > 709) {  // e^a overflows; e^a cos t may not
    const double half = std::exp(0.5 * p.a);
    return on_plane(p, (half * c) * half, (half * s) * half);
  }
  const double ea = std::exp(p.a);
  return on_plane(p, ea * c, ea * s);
}

Quat qlog(const Quat& q) {
  const Plane p = plane_of(q);
  return on_plane(p, log_abs(q, p), std::atan2(p.t, p.a));
}

Quat qsqrt(const Quat& q) {
  const Plane p = plane_of(q);
  if (p.t == 0) {
    if (p.a >= 0) return Quat(std::sqrt(p.a));
    return on_plane(p, 0, std::sqrt(-p.a));
  }
  // sqrt(4^k q) = 2^k sqrt(q): out of range, scale by an even power of two.
  const int e = norm2_in_range(p) != 0 ? 0 : scale_exponent(q) & ~1;
  const double a = std::scalbn(p.a, -e), t = std::scalbn(p.t, -e);
  const double r = std::sqrt(e == 0 ? p.a * p.a + t2(p) : a * a + t * t);
  // Principal root of a + t i: the larger part from a square root without cancellation, the
  // other as t / (2 larger).
  double re, im;
  if (a >= 0) {
    re = std::sqrt(0.5 * (r + a));
    im = t / (2 * re);
  } else {
    im = std::sqrt(0.5 * (r - a));
    re = t / (2 * im);
  }
  return on_plane(p, std::scalbn(re, e / 2), std::scalbn(im, e / 2));
}

Quat qsin(const Quat& q) {
  const Plane p = plane_of(q);
  double ch, sh;
  cosh_sinh(p.t, &ch, &sh);
  return on_plane(p, std::sin(p.a) * ch, std::cos(p.a) * sh);
}

Quat qcos(const Quat& q) {
  const Plane p = plane_of(q);
  double ch, sh;
  cosh_sinh(p.t, &ch, &sh);
  return on_plane(p, std::cos(p.a) * ch, -std::sin(p.a) * sh);
}

Quat qtan(const Quat& q) {
  // tan z = -i tanh(i z); for z = a + t i that is Im + i Re of tanh(t + a i) (tanh is odd).
  const Plane p = plane_of(q);
  double re, im;
  complex_tanh(p.t, p.a, &re, &im);
  return on_plane(p, im, re);
}

Quat qsinh(const Quat& q) {
  Quat ch, sh;
  quat_cosh_sinh(q, &ch, &sh);
  return sh;
}

Quat qcosh(const Quat& q) {
  Quat ch, sh;
  quat_cosh_sinh(q, &ch, &sh);
  return ch;
}

Quat qtanh(const Quat& q) {
  const Plane p = plane_of(q);
  double re, im;
  complex_tanh(p.a, p.t, &re, &im);
  return on_plane(p, re, im);
}

Quat qpow(const Quat& q, double x) {
  const Plane p = plane_of(q);
  if (p.t == 0) {
    if (p.a >= 0) return Quat(std::pow(p.a, x));  // also 0^x: 0 or +inf
    const double m = std::pow(-p.a, x), angle = x * kPi;
    return on_plane(p, m * std::cos(angle), m * std::sin(angle));
  }
  const double angle = x * std::atan2(p.t, p.a);
  double m;
  const double n2 = norm2_in_range(p);
  if (n2 != 0) {
    m = std::pow(n2, 0.5 * x);  // |q|^x from |q|^2: one rounding fewer than sqrt first
  } else {
    // |q|^x = (2^e)^x |q 2^-e|^x, each factor by pow (2^e is exact, also when subnormal).
    const int e = scale_exponent(q);
    m = std::pow(std::ldexp(1.0, e), x) * std::pow(norm2(scaled(q, -e)), 0.5 * x);
  }
  return on_plane(p, m * std::cos(angle), m * std::sin(angle));
}

}  // namespace detail
}  // namespace qjulia
