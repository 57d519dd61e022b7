#include "qjulia/field/quaternion.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <iomanip>
#include <limits>
#include <random>
#include <string>

#include "field/quat_functions.h"

namespace qjulia {
namespace {

TEST(Quaternion, UnitsMultiplyByHamiltonsRules) {
  const Quat i{0, 1, 0, 0}, j{0, 0, 1, 0}, k{0, 0, 0, 1};
  const Quat ij = i * j, ji = j * i, ii = i * i, ijk = i * j * k;
  EXPECT_EQ(ij.z, 1.0);
  EXPECT_EQ(ji.z, -1.0);
  EXPECT_EQ(ii.w, -1.0);
  EXPECT_EQ(ijk.w, -1.0);
}

TEST(Quaternion, SquareEqualsProductWithItself) {
  const Quat q{0.3, -1.2, 0.7, 2.5};
  const Quat a = sqr(q), b = q * q;
  EXPECT_DOUBLE_EQ(a.w, b.w);
  EXPECT_DOUBLE_EQ(a.x, b.x);
  EXPECT_DOUBLE_EQ(a.y, b.y);
  EXPECT_DOUBLE_EQ(a.z, b.z);
}

TEST(Quaternion, RightDivisionUndoesRightMultiplication) {
  const Quat a{1, 2, -3, 0.5}, b{-0.4, 0.1, 2, 1};
  const Quat r = (a * b) / b;
  EXPECT_NEAR(r.w, a.w, 1e-12);
  EXPECT_NEAR(r.x, a.x, 1e-12);
  EXPECT_NEAR(r.y, a.y, 1e-12);
  EXPECT_NEAR(r.z, a.z, 1e-12);
}

TEST(Quaternion, NormIsMultiplicative) {
  const Quat a{1, 2, -3, 0.5}, b{-0.4, 0.1, 2, 1};
  EXPECT_NEAR(abs(a * b), abs(a) * abs(b), 1e-12);
}

TEST(Quaternion, InverseOfZeroIsNotFinite) { EXPECT_FALSE(is_finite(inv(Quat{}))); }

// ---------------------------------------------------------------------------------------------
// The analytic functions of field/quat_functions.h.

using detail::qcos;
using detail::qcosh;
using detail::qexp;
using detail::qlog;
using detail::qpow;
using detail::qsin;
using detail::qsinh;
using detail::qsqrt;
using detail::qtan;
using detail::qtanh;

using CL = std::complex<long double>;
constexpr double kEps = std::numeric_limits<double>::epsilon();

struct Analytic {
  const char* name;
  Quat (*quat)(const Quat&);
  CL (*complex)(const CL&);
  CL (*derivative)(const CL&);
  double max_re, max_im;  // |a|, |b| up to these keep f(a + b i) finite
};

const Analytic kAnalytic[] = {
    {"exp", qexp, [](const CL& z) { return std::exp(z); }, [](const CL& z) { return std::exp(z); },
     700, 1e6},
    {"log", qlog, [](const CL& z) { return std::log(z); }, [](const CL& z) { return 1.0L / z; },
     1e300, 1e300},
    {"sqrt", qsqrt, [](const CL& z) { return std::sqrt(z); },
     [](const CL& z) { return 0.5L / std::sqrt(z); }, 1e300, 1e300},
    {"sin", qsin, [](const CL& z) { return std::sin(z); }, [](const CL& z) { return std::cos(z); },
     1e6, 700},
    {"cos", qcos, [](const CL& z) { return std::cos(z); }, [](const CL& z) { return -std::sin(z); },
     1e6, 700},
    {"tan", qtan, [](const CL& z) { return std::tan(z); },
     [](const CL& z) { return 1.0L + std::tan(z) * std::tan(z); }, 1e6, 1e300},
    {"sinh", qsinh, [](const CL& z) { return std::sinh(z); },
     [](const CL& z) { return std::cosh(z); }, 700, 1e6},
    {"cosh", qcosh, [](const CL& z) { return std::cosh(z); },
     [](const CL& z) { return std::sinh(z); }, 700, 1e6},
    {"tanh", qtanh, [](const CL& z) { return std::tanh(z); },
     [](const CL& z) { return 1.0L - std::tanh(z) * std::tanh(z); }, 1e300, 1e6},
};

/// A random real of either sign with a magnitude spread over many decades below `max`, now
/// and then tiny (down to 1e-300) or exactly 0.
double random_real(std::mt19937_64& rng, double max) {
  std::uniform_real_distribution<double> unit(0, 1);
  const double r = unit(rng);
  if (r < 0.05) return 0;
  const double decade = r < 0.15 ? -300 * unit(rng) : -12 + unit(rng) * (std::log10(max) + 12);
  return (unit(rng) < 0.5 ? -1 : 1) * std::pow(10.0, decade);
}

/// Largest component error of `q` against the complex value X + Y i (long double).
long double complex_error(const Quat& q, const CL& ref) {
  return std::max({std::abs(q.w - ref.real()), std::abs(q.x - ref.imag()),
                   static_cast<long double>(std::abs(q.y)),
                   static_cast<long double>(std::abs(q.z))});
}

TEST(QuatFunctions, AgreeWithStdComplexWithinAFewUlpOnTheComplexPlane) {
  // q = a + b i with b of either sign is the complex number a + b i (u = +-i, and u = i for
  // b = +0, the side from which std::complex approaches the cut). The reference is
  // std::complex<long double>, eleven bits more exact than the double results.
  std::mt19937_64 rng(15);
  for (const Analytic& f : kAnalytic) {
    SCOPED_TRACE(f.name);
    int compared = 0;
    long double worst = 0;  // in ulp of |f|
    for (int n = 0; n < 40000; ++n) {
      const double a = random_real(rng, f.max_re),
                   b = std::abs(random_real(rng, f.max_im)) * (n % 2 ? -1 : 1);
      const CL ref = f.complex(CL(a, b == 0 ? 0.0 : b));
      const long double size = std::abs(ref);
      if (!std::isfinite(static_cast<double>(size))) continue;
      const Quat q = f.quat(Quat(a, b, 0, 0));
      const long double error = complex_error(q, ref);
      if (size > 1e-290L) worst = std::max(worst, error / (kEps * size));
      ASSERT_LE(error, 4 * kEps * size + 1e-300L)
          << std::setprecision(17) << f.name << "(" << a << " + " << b << " i) = " << q.w << " + "
          << q.x << " i, std::complex " << static_cast<double>(ref.real()) << " + "
          << static_cast<double>(ref.imag()) << " i";
      ++compared;
    }
    EXPECT_GT(compared, 39000);
    std::printf("%-5s largest error %.2f ulp of |f| on %d points\n", f.name,
                static_cast<double>(worst), compared);
  }
}

TEST(QuatFunctions, ActInThePlaneOfTheirArgument) {
  // q = a + b n for a unit vector n and b > 0 behaves as a + b i: f(q) = X + Y n. The vector
  // b n is rounded, so the bound adds that input error times |f'|.
  std::mt19937_64 rng(16);
  std::normal_distribution<double> normal;
  for (const Analytic& f : kAnalytic) {
    SCOPED_TRACE(f.name);
    for (int n = 0; n < 20000; ++n) {
      const double a = random_real(rng, 20), b = std::abs(random_real(rng, 20));
      if (b == 0) continue;  // no plane: u = i, tested below
      double d[3] = {normal(rng), normal(rng), normal(rng)};
      const double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
      for (double& c : d) c /= len;
      const Quat q(a, b * d[0], b * d[1], b * d[2]);
      const Quat r = f.quat(q);
      const CL z(a, b);
      const CL ref = f.complex(z);
      const long double tolerance =
          8 * kEps * (std::abs(ref) + std::abs(z) * std::abs(f.derivative(z))) + 1e-300L;
      ASSERT_LE(std::abs(r.w - ref.real()), tolerance) << a << " " << b;
      for (int c = 0; c < 3; ++c)
        ASSERT_LE(std::abs(r[c + 1] - ref.imag() * d[c]), tolerance) << a << " " << b << " " << c;
    }
  }
}

TEST(QuatFunctions, RealPowersAgreeWithStdComplexAndScaleWithTheExponent) {
  // q^x = |q|^x (cos x theta + u sin x theta): the angle carries |x| times the half ulp of
  // theta = atan2(t, a) <= pi (1.6 |x| ulp of |f|), |q^2|^(x/2) |x|/2 times the 1.5 ulp of
  // |q|^2 (0.75 |x| ulp); the bound adds 4 ulp for the rest.
  std::mt19937_64 rng(17);
  for (double x : {0.5, -0.5, 1.5, -1.5, 2.5, 0.25, 7.3, -63.5}) {
    SCOPED_TRACE("x = " + std::to_string(x));
    const double max = std::pow(10.0, 300 / std::abs(x));
    long double worst = 0;  // in ulp of |f|
    for (int n = 0; n < 20000; ++n) {
      const double a = random_real(rng, max), b = random_real(rng, max);
      const CL z(a, b == 0 ? 0.0 : b);
      const CL ref = (b == 0 && a >= 0) ? CL(std::pow(static_cast<long double>(a), x), 0)
                                        : std::exp(static_cast<long double>(x) * std::log(z));
      const long double size = std::abs(ref);
      if (!std::isfinite(static_cast<double>(size))) continue;
      const Quat q = qpow(Quat(a, b, 0, 0), x);
      const long double error = complex_error(q, ref);
      if (size > 1e-290L) worst = std::max(worst, error / (kEps * size));
      ASSERT_LE(error, (4 + 2.5 * std::abs(x)) * kEps * size + 1e-300L)
          << std::setprecision(17) << "(" << a << " + " << b << " i)^" << x;
    }
    std::printf("x = %-5g largest error %.2f ulp of |f|\n", x, static_cast<double>(worst));
  }
}

/// A random quaternion with components in [-s, s].
Quat random_quat(std::mt19937_64& rng, double s) {
  std::uniform_real_distribution<double> u(-s, s);
  return {u(rng), u(rng), u(rng), u(rng)};
}

void expect_close(const Quat& a, const Quat& b, double tolerance) {
  EXPECT_LE(abs(a - b), tolerance)
      << "(" << a.w << ", " << a.x << ", " << a.y << ", " << a.z << ") vs (" << b.w << ", " << b.x
      << ", " << b.y << ", " << b.z << ")";
}

TEST(QuatFunctions, SatisfyTheIdentitiesOfTheirComplexFunctions) {
  std::mt19937_64 rng(18);
  for (int n = 0; n < 2000; ++n) {
    const Quat q = random_quat(rng, 3);
    const double size = abs(q);
    expect_close(qexp(qlog(q)), q, 1e-14 * size * (1 + abs(qlog(q))));
    const Quat half = 0.5 * q;  // |vector part| < pi: log inverts exp there
    expect_close(qlog(qexp(half)), half, 1e-14 * (1 + size));
    const Quat s = qsin(q), c = qcos(q);
    expect_close(sqr(s) + sqr(c), Quat(1), 1e-14 * (1 + norm2(s) + norm2(c)));
    expect_close(qtan(q), s * inv(c), 1e-14 * (1 + abs(qtan(q))) * (1 + norm2(c) * norm2(inv(c))));
    const Quat sh = qsinh(q), ch = qcosh(q), e = qexp(q), em = qexp(-q);
    expect_close(sh, 0.5 * (e - em), 1e-14 * (abs(e) + abs(em)));
    expect_close(ch, 0.5 * (e + em), 1e-14 * (abs(e) + abs(em)));
    expect_close(sqr(ch) - sqr(sh), Quat(1), 1e-14 * (1 + norm2(ch) + norm2(sh)));
    expect_close(qtanh(q), sh * inv(ch), 1e-14 * (1 + abs(qtanh(q))) * abs(ch) * abs(inv(ch)));
    const Quat r = qsqrt(q);
    EXPECT_GE(r.w, 0);
    expect_close(sqr(r), q, 2e-15 * size);
    expect_close(sqr(qpow(q, 0.5)), q, 4e-15 * size);
    expect_close(qpow(q, 0.5), r, 1e-15 * abs(r));
    expect_close(qpow(q, 1.5), q * r, 1e-15 * size * abs(r));
    expect_close(qpow(q, -1.5) * qpow(q, 1.5), Quat(1), 1e-14);
    // Real coefficients: f(conj q) = conj f(q), f commutes with q.
    expect_close(qsin(conj(q)), conj(s), 1e-15 * (1 + abs(s)));
    expect_close(q * s, s * q, 1e-14 * size * abs(s));
  }
}

TEST(QuatFunctions, ExpOfAPurelyImaginaryQuaternionIsAUnit) {
  std::mt19937_64 rng(19);
  for (int n = 0; n < 2000; ++n) {
    Quat v = random_quat(rng, n < 1000 ? 4 : 1e6);
    v.w = 0;
    EXPECT_NEAR(abs(qexp(v)), 1, 4 * kEps);
  }
}

TEST(QuatFunctions, TakeTheAxisIWhereTheVectorPartVanishes) {
  const double pi = std::acos(-1.0);
  expect_close(qlog(Quat(-1)), Quat(0, pi, 0, 0), 0);
  expect_close(qlog(Quat(-std::exp(2.0))), Quat(2, pi, 0, 0), 4 * kEps);
  expect_close(qsqrt(Quat(-4)), Quat(0, 2, 0, 0), 0);
  expect_close(qpow(Quat(-4), 0.5), Quat(0, 2, 0, 0), 4 * kEps);
  expect_close(qpow(Quat(-8), 1.0 / 3), Quat(1, std::sqrt(3.0), 0, 0), 8 * kEps);
  // Real arguments on the real functions stay real, exactly as the real functions.
  for (double a : {-3.0, -0.5, 0.0, 0.25, 2.0, 40.0}) {
    EXPECT_EQ(qexp(Quat(a)).w, std::exp(a));
    EXPECT_EQ(qsin(Quat(a)).w, std::sin(a));
    EXPECT_EQ(qcos(Quat(a)).w, std::cos(a));
    EXPECT_EQ(qtan(Quat(a)).w, std::tan(a));
    for (const Quat& r : {qexp(Quat(a)), qsin(Quat(a)), qcos(Quat(a)), qtan(Quat(a)),
                          qsinh(Quat(a)), qcosh(Quat(a)), qtanh(Quat(a))})
      EXPECT_EQ(abs(Quat(0, r.x, r.y, r.z)), 0);
    EXPECT_NEAR(qsinh(Quat(a)).w, std::sinh(a), 2 * kEps * std::cosh(a));
    EXPECT_NEAR(qcosh(Quat(a)).w, std::cosh(a), 2 * kEps * std::cosh(a));
    EXPECT_NEAR(qtanh(Quat(a)).w, std::tanh(a), 2 * kEps);
  }
  // Tiny vector parts keep their direction and size (no underflow of |v|^2).
  const Quat tiny(1, 3e-200, -4e-200, 0);
  expect_close(qexp(tiny), std::exp(1.0) * Quat(1, 3e-200, -4e-200, 0), 4 * kEps);
  const Quat l = qlog(Quat(-1, 3e-200, 4e-200, 0));
  EXPECT_NEAR(l.x, 0.6 * pi, 4 * kEps);
  EXPECT_NEAR(l.y, 0.8 * pi, 4 * kEps);
  const Quat big = qsqrt(Quat(0, 3e300, 4e300, 0));
  expect_close(big, std::sqrt(2.5e300) * Quat(1, 0.6, 0.8, 0), 8 * kEps * abs(big));
}

TEST(QuatFunctions, PolesAndOverflowGiveNonFiniteValues) {
  EXPECT_EQ(qlog(Quat()).w, -HUGE_VAL);
  EXPECT_FALSE(is_finite(qpow(Quat(), -1.5)));
  expect_close(qpow(Quat(), 1.5), Quat(), 0);
  EXPECT_FALSE(is_finite(qexp(Quat(800, 0.1, 0, 0))));
  EXPECT_FALSE(is_finite(qexp(Quat(800))));
  EXPECT_FALSE(is_finite(qsin(Quat(1, 0, 800, 0))));
  EXPECT_FALSE(is_finite(qcos(Quat(1, 0, 0, 800))));
  EXPECT_FALSE(is_finite(qsinh(Quat(800, 1, 0, 0))));
  EXPECT_FALSE(is_finite(qcosh(Quat(-800, 1, 0, 0))));
  // e^a cos t stays finite past the overflow of e^a when cos t is small enough.
  EXPECT_TRUE(is_finite(qexp(Quat(710, 0.785, 0, 0))));
  EXPECT_FALSE(std::isfinite(std::exp(710.0)));
  // tan and tanh saturate instead of overflowing: tan(a + t u) -> u, tanh(a + v) -> sign(a).
  expect_close(qtan(Quat(1, 0, 800, 0)), Quat(0, 0, 1, 0), 0);
  expect_close(qtanh(Quat(-800, 1, 2, 3)), Quat(-1), 0);
  // At the poles of tan (pi/2 is not a double) it gives large finite values.
  const Quat pole = qtan(Quat(std::acos(-1.0) / 2));
  EXPECT_TRUE(is_finite(pole));
  EXPECT_GT(pole.w, 1e15);
  // Non-finite in, non-finite out, without hanging in the scaling paths.
  for (Quat (*f)(const Quat&) : {qexp, qlog, qsqrt, qsin, qcos, qtan, qsinh, qcosh, qtanh}) {
    if (f != qtanh) {
      EXPECT_FALSE(is_finite(f(Quat(HUGE_VAL, 1, 0, 0))));
    }
    EXPECT_FALSE(is_finite(f(Quat(1, std::nan(""), 0, 0))));
  }
  expect_close(qtanh(Quat(HUGE_VAL, 1, 0, 0)), Quat(1), 0);  // the limit
  EXPECT_FALSE(is_finite(qpow(Quat(1, HUGE_VAL, 0, 0), 0.5)));
}

}  // namespace
}  // namespace qjulia
