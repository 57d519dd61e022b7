#include "qjulia/field/classify.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "qjulia/base/error.h"
#include "qjulia/field/params.h"

namespace qjulia {
namespace {

constexpr double kPi = 3.14159265358979323846;

Params make_params(const std::string& formula, Method method, int iterations, double bailout) {
  Params p;
  p.formula = formula;
  p.method = method;
  p.iterations = iterations;
  p.bailout = bailout;
  return p;
}

Params newton_cutoff() { return make_params("(2*h^3+1)/(3*h^2)", Method::kCutoff, 12, 0.01); }
Params newton_escape() { return make_params("(2*h^3+1)/(3*h^2)", Method::kEscape, 12, 2); }
Params rosa_cutoff() {
  return make_params("(2*h^3-2*h^2-3)/(3*h^2+4*h+1)", Method::kCutoff, 12, 0.01);
}
Params classic_julia() {
  Params p = make_params("h^2+c", Method::kEscape, 10, 4);
  p.set_constant("c", {-0.2, 0.8, 0, 0});
  return p;
}
Params mandelbrot() {
  Params p = make_params("h^2+c", Method::kEscape, 12, 4);
  p.mode = Mode::kMandelbrot;
  return p;
}
Params pq_quadratic() {
  Params p = make_params("p*h^2+q", Method::kEscape, 10, 4);
  p.set_constant("p", {0.9, 0.3, 0.2, 0.1});
  p.set_constant("q", {-0.3, 0.5, 0.3, 0.1});
  return p;
}

struct Point {
  double x, y, z;
};

std::vector<Point> random_points(int count, double lo, double hi, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(lo, hi);
  std::vector<Point> out;
  for (int i = 0; i < count; ++i) out.push_back({u(rng), u(rng), u(rng)});
  return out;
}

// ---------------------------------------------------------------------------------------------
// An independent implementation of the table of docs/design.md on quaternion.h's arithmetic: the
// map is given as C++ code, not as a formula, so it shares nothing with the formula compiler.

using Map = std::function<Quat(const Quat&)>;

// In the solid by the method's definition: escape: |h_k| <= R for k in 0..N; cutoff:
// |h_k - h_(k-1)| >= R for k in 1..N. A non-finite value escapes / is a large step.
bool reference_inside(const Map& f, Quat h, Method method, int n, double r) {
  if (method == Method::kEscape) {
    if (!(abs(h) <= r)) return false;
    for (int k = 1; k <= n; ++k) {
      h = f(h);
      if (!is_finite(h) || !(abs(h) <= r)) return false;
    }
    return true;
  }
  for (int k = 1; k <= n; ++k) {
    const Quat next = f(h);
    if (!is_finite(next)) return true;  // a large step; the orbit stays at infinity
    if (abs(next - h) < r) return false;
    h = next;
  }
  return true;
}

// True when the fate of the reference changes within `eps` of p (along the axes): such points
// are "on the boundary" and two correct implementations may round them differently.
template <class Inside>
bool near_boundary(const Inside& inside, const Point& p, double eps) {
  const bool here = inside(p.x, p.y, p.z);
  for (int a = 0; a < 3; ++a)
    for (double s : {-eps, eps}) {
      Point q = p;
      (a == 0 ? q.x : a == 1 ? q.y : q.z) += s;
      if (inside(q.x, q.y, q.z) != here) return true;
    }
  return false;
}

// ---------------------------------------------------------------------------------------------
// The unit ball

TEST(Classify, EscapeWithHSquaredAndRadiusOneIsExactlyTheClosedUnitBall) {
  const Classifier cl(make_params("h^2", Method::kEscape, 10, 1));
  int inside = 0, outside = 0;
  for (const Point& p : random_points(20000, -1.5, 1.5, 1)) {
    const double r = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
    if (std::abs(r - 1) < 1e-12) continue;
    const bool in = cl.inside(p.x, p.y, p.z);
    EXPECT_EQ(in, r <= 1) << p.x << " " << p.y << " " << p.z << " r=" << r;
    (in ? inside : outside)++;
  }
  EXPECT_GT(inside, 1000);
  EXPECT_GT(outside, 1000);
}

TEST(Classify, PointsJustInsideAndJustOutsideTheUnitSphereAreClassifiedExactly) {
  const Classifier cl(make_params("h^2", Method::kEscape, 10, 1));
  std::mt19937_64 rng(2);
  std::normal_distribution<double> g;
  for (int i = 0; i < 2000; ++i) {
    double d[3] = {g(rng), g(rng), g(rng)};
    const double n = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (double& v : d) v /= n;
    const double in = 1 - 1e-9, out = 1 + 1e-9;
    EXPECT_TRUE(cl.inside(in * d[0], in * d[1], in * d[2])) << d[0] << " " << d[1] << " " << d[2];
    EXPECT_FALSE(cl.inside(out * d[0], out * d[1], out * d[2]))
        << d[0] << " " << d[1] << " " << d[2];
  }
  // On the axes the radius is exact.
  EXPECT_TRUE(cl.inside(1, 0, 0));
  EXPECT_TRUE(cl.inside(0, -1, 0));
  EXPECT_TRUE(cl.inside(0, 0, 1));
  EXPECT_FALSE(cl.inside(std::nextafter(1.0, 2.0), 0, 0));
}

TEST(Classify, EscapeWithHSquaredAndRadiusTwoIsTheBallOfRadiusTwoToTheMinusTwoToTheN) {
  // |h_k| = |h_0|^(2^k), so the level-N solid is |h_0| <= R^(1/2^N).
  const int n = 6;
  const double r = 2;
  const Classifier cl(make_params("h^2", Method::kEscape, n, r));
  const double radius = std::pow(r, 1.0 / std::pow(2.0, n));
  for (const Point& p : random_points(20000, -1.2, 1.2, 3)) {
    const double rho = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
    if (std::abs(rho - radius) < 1e-12) continue;
    EXPECT_EQ(cl.inside(p.x, p.y, p.z), rho <= radius) << rho << " vs " << radius;
  }
}

TEST(Classify, TheOriginOfTheUnitBallHasAFiniteNegativeField) {
  const Classifier cl(make_params("h^2", Method::kEscape, 10, 1));
  const Orbit o = cl.orbit(0, 0, 0);
  EXPECT_TRUE(std::isfinite(o.field));
  EXPECT_LT(o.field, 0);
  EXPECT_EQ(o.exit_step, -1);
}

// ---------------------------------------------------------------------------------------------
// The sign of F is the method's decision; F is never NaN

TEST(Classify, FieldSignEqualsTheDecisionOfTheMethodForEveryKindOfMap) {
  const Quat p = {0.9, 0.3, 0.2, 0.1}, q = {-0.3, 0.5, 0.3, 0.1}, c = {-0.2, 0.8, 0, 0};
  const struct {
    const char* name;
    Params params;
    Map map;
  } cases[] = {
      {"newton cutoff", newton_cutoff(),
       [](const Quat& h) { return (2.0 * (h * h * h) + Quat(1)) * inv(3.0 * (h * h)); }},
      {"newton escape", newton_escape(),
       [](const Quat& h) { return (2.0 * (h * h * h) + Quat(1)) * inv(3.0 * (h * h)); }},
      {"rosa cutoff", rosa_cutoff(),
       [](const Quat& h) {
         return (2.0 * (h * h * h) - 2.0 * (h * h) - Quat(3)) *
                inv(3.0 * (h * h) + 4.0 * h + Quat(1));
       }},
      {"classic julia", classic_julia(), [c](const Quat& h) { return h * h + c; }},
      // Non-commutative: p multiplies on the left.
      {"p*h^2+q", pq_quadratic(), [p, q](const Quat& h) { return p * (h * h) + q; }},
  };
  for (const auto& cs : cases) {
    SCOPED_TRACE(cs.name);
    const Classifier cl(cs.params);
    const auto ref = [&](double x, double y, double z) {
      return reference_inside(cs.map, cl.to_quaternion(x, y, z), cs.params.method,
                              cs.params.iterations, cs.params.bailout);
    };
    int inside = 0, outside = 0, boundary = 0;
    for (const Point& pt : random_points(6000, -2, 2, 4)) {
      const Orbit o = cl.orbit(pt.x, pt.y, pt.z);
      ASSERT_FALSE(std::isnan(o.field)) << pt.x << " " << pt.y << " " << pt.z;
      EXPECT_EQ(cl.inside(pt.x, pt.y, pt.z), o.field <= 0);
      const bool want = ref(pt.x, pt.y, pt.z);
      if ((o.field <= 0) != want) {
        ++boundary;
        EXPECT_TRUE(near_boundary(ref, pt, 1e-9))
            << "classified " << (want ? "outside" : "inside") << " (F = " << o.field
            << ") but the method says otherwise at " << pt.x << " " << pt.y << " " << pt.z;
      }
      (want ? inside : outside)++;
    }
    EXPECT_GT(inside, 100);
    EXPECT_GT(outside, 100);
    EXPECT_LT(boundary, 6);  // points within 1e-9 of the boundary are rare
  }
}

TEST(Classify, FieldIsNeverNaNAtPolesHugeAndTinyPoints) {
  const double huge = 1e300, tiny = 1e-300, preimage = -std::cbrt(0.5);  // T(preimage) = 0
  const Point points[] = {{0, 0, 0},      {huge, 0, 0},  {-huge, huge, 0},   {huge, huge, huge},
                          {tiny, 0, 0},   {0, tiny, 0},  {tiny, tiny, tiny}, {preimage, 0, 0},
                          {0, 1e-160, 0}, {1e154, 0, 0}, {-1e200, 0, 1e-200}};
  const struct {
    const char* name;
    Params params;
  } cases[] = {
      {"newton cutoff", newton_cutoff()},
      {"newton escape", newton_escape()},
      {"rosa cutoff", rosa_cutoff()},
      {"classic julia", classic_julia()},
      {"mandelbrot", mandelbrot()},
      {"p*h^2+q", pq_quadratic()},
      {"h^-2 cutoff", make_params("h^-2", Method::kCutoff, 8, 0.01)},
      {"inv(h) escape", make_params("inv(h)+h^3", Method::kEscape, 8, 0.8)},
  };
  for (const auto& cs : cases) {
    const Classifier cl(cs.params);
    for (const Point& p : points) {
      const Orbit o = cl.orbit(p.x, p.y, p.z);
      EXPECT_FALSE(std::isnan(o.field)) << cs.name << " at " << p.x << " " << p.y << " " << p.z;
      EXPECT_TRUE(is_finite(o.last)) << cs.name << " at " << p.x << " " << p.y << " " << p.z;
    }
  }
}

TEST(Classify, NewtonsPoleIsALargeStepForCutoffAndAnEscapeForEscape) {
  // h0 = 0: 3 h^2 = 0, so h1 is a pole.
  const Classifier cut(newton_cutoff());
  const Orbit c = cut.orbit(0, 0, 0);
  EXPECT_FALSE(std::isnan(c.field));
  EXPECT_LE(c.field, 0) << "a pole is a large step: the orbit never converges";
  EXPECT_EQ(c.exit_step, -1);

  const Params pe = newton_escape();
  const Classifier esc(pe);
  const Orbit e = esc.orbit(0, 0, 0);
  EXPECT_FALSE(std::isnan(e.field));
  EXPECT_GT(e.field, 0) << "a pole is an escape";
  EXPECT_EQ(e.exit_step, 1);
  EXPECT_GE(e.field, pe.iterations - 1);
  EXPECT_LE(e.field, pe.iterations);
}

TEST(Classify, HugePointsEscapeAtStepZero) {
  const Params p = classic_julia();
  const Classifier cl(p);
  for (double v : {1e300, -1e300, 1e200, 5.0}) {
    const Orbit o = cl.orbit(v, 0, 0);
    EXPECT_EQ(o.exit_step, 0) << v;
    EXPECT_GT(o.field, p.iterations) << v;
    EXPECT_LE(o.field, p.iterations + 1) << v;
  }
}

TEST(Classify, AnOrbitThatLeavesRightAfterStartingAtZeroIsOutside) {
  // h0 = 0 (|h0| = 0, so s_0 = -infinity), h1 = c with |c| = 5 > R = 4: the orbit escapes at
  // step 1, so with N = 1 the point is outside.
  Params julia = make_params("h^2+c", Method::kEscape, 1, 4);
  julia.set_constant("c", Quat(5));
  const Orbit j = Classifier(julia).orbit(0, 0, 0);
  EXPECT_EQ(j.exit_step, 1);
  EXPECT_GT(j.field, 0) << "escaped at step 1 of 1, yet F says inside";

  Params mandel = mandelbrot();
  mandel.iterations = 1;
  const Classifier m(mandel);
  EXPECT_FALSE(m.inside(5, 0, 0)) << "c = 5 escapes at step 1 of 1, yet F = " << m.field(5, 0, 0);
  EXPECT_FALSE(m.inside(0, 0, -4.5)) << "F = " << m.field(0, 0, -4.5);
}

// ---------------------------------------------------------------------------------------------
// F in (N-n, N-n+1] when the orbit exits at step n

TEST(Classify, FieldLiesInTheBandOfTheExitStep) {
  const struct {
    const char* name;
    Params params;
  } cases[] = {
      {"newton cutoff", newton_cutoff()},
      {"newton escape", newton_escape()},
      {"rosa cutoff", rosa_cutoff()},
      {"classic julia", classic_julia()},
      {"mandelbrot", mandelbrot()},
      {"p*h^2+q", pq_quadratic()},
      {"h^2 - 0.5, R = 0.8", make_params("h^2-0.5", Method::kEscape, 8, 0.8)},
  };
  for (const auto& cs : cases) {
    SCOPED_TRACE(cs.name);
    const Classifier cl(cs.params);
    const int n_iter = cs.params.iterations;
    std::vector<int> seen(n_iter + 2, 0);
    for (const Point& p : random_points(5000, -2.5, 2.5, 5)) {
      const Orbit o = cl.orbit(p.x, p.y, p.z);
      if (o.exit_step < 0) {
        EXPECT_LE(o.field, 0) << p.x << " " << p.y << " " << p.z;
        ++seen[n_iter + 1];
        continue;
      }
      ASSERT_LE(o.exit_step, n_iter);
      ++seen[o.exit_step];
      const int n = o.exit_step;
      // (N-n, N-n+1]; the lower end may be reached by rounding F to float, never passed.
      EXPECT_GT(o.field, 0) << "exit step " << n;
      EXPECT_GE(o.field, static_cast<float>(n_iter - n)) << "exit step " << n;
      EXPECT_LE(o.field, static_cast<float>(n_iter - n + 1)) << "exit step " << n;
    }
    int kinds = 0;
    for (int s : seen) kinds += s > 0;
    EXPECT_GE(kinds, 3) << "the sample should meet several exit steps";
  }
}

// ---------------------------------------------------------------------------------------------
// Continuity of F

TEST(Classify, FieldChangesLittleBetweenClosePointsWithTheSameExitStep) {
  for (const Params& params : {classic_julia(), newton_cutoff(), rosa_cutoff()}) {
    SCOPED_TRACE(params.formula);
    const Classifier cl(params);
    std::mt19937_64 rng(6);
    std::normal_distribution<double> g;
    int pairs = 0, jumps = 0;
    double worst_typical = 0;
    std::vector<double> changes;
    for (const Point& p : random_points(5000, -2, 2, 7)) {
      const double d = 1e-7;
      const Point q{p.x + d * g(rng), p.y + d * g(rng), p.z + d * g(rng)};
      const Orbit a = cl.orbit(p.x, p.y, p.z), b = cl.orbit(q.x, q.y, q.z);
      if (a.exit_step != b.exit_step || std::abs(a.field) >= 1e5) continue;  // skip poles
      ++pairs;
      const double change = std::abs(double(a.field) - double(b.field));
      changes.push_back(change);
      if (change > 0.05) ++jumps;
    }
    ASSERT_GT(pairs, 4000);
    std::sort(changes.begin(), changes.end());
    worst_typical = changes[changes.size() * 99 / 100];
    EXPECT_LT(worst_typical, 1e-3) << "99% of pairs 1e-7 apart change F by less than 1e-3";
    EXPECT_LE(jumps, pairs / 500) << "a jump of 0.05 over 1e-7 is a discontinuity";
  }
}

// Bisects [in, out] on the exact classification down to `tol` and returns the two ends.
std::pair<Point, Point> bisect(const Classifier& cl, Point in, Point out, double tol) {
  for (int i = 0; i < 200; ++i) {
    const double dist =
        std::sqrt((in.x - out.x) * (in.x - out.x) + (in.y - out.y) * (in.y - out.y) +
                  (in.z - out.z) * (in.z - out.z));
    if (dist < tol) break;
    const Point mid{0.5 * (in.x + out.x), 0.5 * (in.y + out.y), 0.5 * (in.z + out.z)};
    (cl.inside(mid.x, mid.y, mid.z) ? in : out) = mid;
  }
  return {in, out};
}

TEST(Classify, FieldCrossesZeroExactlyWhereTheClassificationChanges) {
  // With R above the escape radius (h^2 + c, R = 4) an orbit that reaches R leaves for good, so
  // the decision only changes at step N and F is near 0 on both sides of the boundary.
  for (const Params& params : {classic_julia(), newton_cutoff()}) {
    SCOPED_TRACE(params.formula);
    const Classifier cl(params);
    std::vector<Point> ins, outs;
    for (const Point& p : random_points(4000, -1.5, 1.5, 8))
      (cl.inside(p.x, p.y, p.z) ? ins : outs).push_back(p);
    ASSERT_GT(ins.size(), 50u);
    ASSERT_GT(outs.size(), 50u);
    double worst = 0;
    for (int i = 0; i < 200; ++i) {
      const auto [a, b] = bisect(cl, ins[i % ins.size()], outs[(7 * i) % outs.size()], 1e-13);
      const float fa = cl.field(a.x, a.y, a.z), fb = cl.field(b.x, b.y, b.z);
      ASSERT_LE(fa, 0);
      ASSERT_GT(fb, 0);
      worst = std::max({worst, double(-fa), double(fb)});
      EXPECT_LT(-fa, 1e-3) << "inside end " << a.x << " " << a.y << " " << a.z;
      EXPECT_LT(fb, 1e-3) << "outside end " << b.x << " " << b.y << " " << b.z;
    }
    RecordProperty("worst_field_at_crossing_" + std::string(to_string(params.method)),
                   std::to_string(worst));
  }
}

// ---------------------------------------------------------------------------------------------
// Symmetry and the complex section

TEST(Classify, RealCoefficientMapsAreSymmetricAboutTheRealAxis) {
  const struct {
    const char* name;
    Params params;
  } cases[] = {
      {"newton cutoff", newton_cutoff()},
      {"rosa cutoff", rosa_cutoff()},
      {"h^2 - 0.5 escape", make_params("h^2-0.5", Method::kEscape, 10, 2)},
  };
  for (const auto& cs : cases) {
    SCOPED_TRACE(cs.name);
    const Classifier cl(cs.params);
    std::mt19937_64 rng(9);
    std::uniform_real_distribution<double> angle(0, 2 * kPi);
    int checked = 0, insides = 0;
    for (const Point& p : random_points(4000, -2, 2, 10)) {
      const float f = cl.field(p.x, p.y, p.z);
      // Points whose field moves by more than the tolerance within 1e-9 are chaotic: rounding
      // of the rotation may legitimately change them.
      bool stable = true;
      for (int a = 0; a < 3 && stable; ++a) {
        Point q = p;
        (a == 0 ? q.x : a == 1 ? q.y : q.z) += 1e-9;
        stable = std::abs(cl.field(q.x, q.y, q.z) - f) < 1e-4f;
      }
      if (!stable) continue;
      ++checked;
      insides += f <= 0;
      const double t = angle(rng), ct = std::cos(t), st = std::sin(t);
      const float rotated = cl.field(p.x, p.y * ct - p.z * st, p.y * st + p.z * ct);
      EXPECT_NEAR(rotated, f, 1e-4 * std::max(1.0f, std::abs(f)))
          << p.x << " " << p.y << " " << p.z << " by " << t;
      // The point behaves as x + i sqrt(y^2 + z^2).
      const float on_plane = cl.field(p.x, std::hypot(p.y, p.z), 0);
      EXPECT_NEAR(on_plane, f, 1e-4 * std::max(1.0f, std::abs(f)));
    }
    EXPECT_GT(checked, 3000);
    EXPECT_GT(insides, 50);
  }
}

// h^2 + c on complex numbers, by docs/design.md's table and field formula.
struct ComplexOrbit {
  bool inside;
  int exit_step;  // -1 if it never left
  double field;   // docs/design.md's F (meaningful for exit_step != 0)
};

ComplexOrbit complex_escape(std::complex<double> z, std::complex<double> c, int n, double r) {
  double s_prev = std::log(std::abs(z) / r);
  if (s_prev > 0) return {false, 0, 0};
  for (int k = 1; k <= n; ++k) {
    z = z * z + c;
    const double s = std::log(std::abs(z) / r);
    if (s > 0) return {false, k, (n - k) + s / (s - s_prev)};
    s_prev = s;
  }
  return {true, -1, s_prev};
}

TEST(Classify, TheSectionZEqualsZeroIsTheComplexFilledInJuliaSet) {
  const Params params = classic_julia();  // c = -0.2 + 0.8i, escape, R = 4, N = 10
  const Classifier cl(params);
  const std::complex<double> c(-0.2, 0.8);
  const auto ref = [&](double x, double y, double) {
    return complex_escape({x, y}, c, params.iterations, params.bailout).inside;
  };
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  int inside = 0, outside = 0, boundary = 0, compared = 0;
  for (int i = 0; i < 40000; ++i) {
    const Point p{u(rng), u(rng), 0};
    const ComplexOrbit want = complex_escape({p.x, p.y}, c, params.iterations, params.bailout);
    const Orbit got = cl.orbit(p.x, p.y, 0);
    (want.inside ? inside : outside)++;
    if ((got.field <= 0) != want.inside) {
      ++boundary;
      EXPECT_TRUE(near_boundary(ref, p, 1e-9)) << p.x << " + " << p.y << "i";
      continue;
    }
    EXPECT_EQ(got.exit_step, want.exit_step) << p.x << " + " << p.y << "i";
    if (want.exit_step != 0 && got.exit_step == want.exit_step) {
      EXPECT_NEAR(got.field, want.field, 1e-5 * std::max(1.0, std::abs(want.field)))
          << p.x << " + " << p.y << "i";
      ++compared;
    }
  }
  EXPECT_GT(inside, 2000);
  EXPECT_GT(outside, 2000);
  EXPECT_LT(boundary, 10);
  EXPECT_GT(compared, 20000);
}

TEST(Classify, TheSliceWithoutKIsInvariantUnderHSquaredPlusAComplexC) {
  // h = w + x i + y j: h^2 = w^2 - x^2 - y^2 + 2w (x i + y j) has no k part, nor has c.
  const Classifier cl(classic_julia());
  int moved = 0;
  for (const Point& p : random_points(5000, -1.5, 1.5, 12)) {
    const Orbit o = cl.orbit(p.x, p.y, p.z);
    EXPECT_EQ(o.last.z, 0.0) << p.x << " " << p.y << " " << p.z;
    moved += o.last.y != p.z;
  }
  EXPECT_GT(moved, 4000) << "the orbits should actually move";
}

// ---------------------------------------------------------------------------------------------
// Mandelbrot mode and the slice

TEST(Classify, MandelbrotModeSamplesTheConstant) {
  const Classifier cl(mandelbrot());  // h^2 + c, h0 = 0, escape, R = 4, N = 12
  EXPECT_TRUE(cl.inside(0, 0, 0)) << "c = 0 stays at 0";
  EXPECT_FALSE(cl.inside(1, 0, 0)) << "c = 1: 0, 1, 2, 5";
  EXPECT_TRUE(cl.inside(-1, 0, 0)) << "c = -1: period 2";
  EXPECT_TRUE(cl.inside(-2, 0, 0)) << "c = -2: 0, -2, 2, 2, ...";
  EXPECT_FALSE(cl.inside(-2.1, 0, 0));
  EXPECT_TRUE(cl.inside(0, 1, 0)) << "c = i: 0, i, -1+i, -i, -1+i, ...";
  EXPECT_TRUE(cl.inside(0, 0, 1)) << "c = j behaves as c = i";
  EXPECT_FALSE(cl.inside(0, 0, 1.2));
  EXPECT_EQ(cl.orbit(1, 0, 0).exit_step, 3);
}

TEST(Classify, MandelbrotModeStartsFromTheGivenStart) {
  Params p = mandelbrot();
  p.start = {5, 0, 0, 0};  // |h0| > R: everything escapes at step 0
  const Classifier cl(p);
  EXPECT_FALSE(cl.inside(0, 0, 0));
  EXPECT_EQ(cl.orbit(0, 0, 0).exit_step, 0);
}

TEST(Classify, TheSliceMapsPointsToQuaternions) {
  Params p = make_params("h^2", Method::kEscape, 10, 1);
  p.slice.axes = "mnp";
  p.slice.fixed = 0.5;
  const Quat q = Classifier(p).to_quaternion(0.1, 0.2, 0.3);
  EXPECT_DOUBLE_EQ(q.w, 0.5);
  EXPECT_DOUBLE_EQ(q.x, 0.1);
  EXPECT_DOUBLE_EQ(q.y, 0.2);
  EXPECT_DOUBLE_EQ(q.z, 0.3);
  // The unit ball cut at real part 0.5 is the ball of radius sqrt(0.75).
  const Classifier cl(p);
  EXPECT_TRUE(cl.inside(0.86, 0, 0));
  EXPECT_FALSE(cl.inside(0.87, 0, 0));
}

TEST(Classify, TheConstructorRejectsInvalidParameters) {
  Params p = classic_julia();
  p.bailout = -1;
  EXPECT_THROW(Classifier{p}, InvalidInput);
  p = classic_julia();
  p.formula = "h^2+d";
  EXPECT_THROW(Classifier{p}, InvalidInput);
}

// ---------------------------------------------------------------------------------------------
// Solid: the box and the clip planes

Params small_box_ball() {
  Params p = make_params("h^2", Method::kEscape, 10, 1);
  p.bounds = {{-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5}};
  p.resolution = 32;
  return p;
}

TEST(Solid, PointsOutsideTheBoxAreOutsideEvenInTheSet) {
  const Solid s(small_box_ball());
  EXPECT_TRUE(s.classifier().inside(0.7, 0, 0));
  EXPECT_FALSE(s.inside(0.7, 0, 0));
  EXPECT_FALSE(s.inside(0, -0.6, 0));
  EXPECT_FALSE(s.inside(0, 0, 0.51));
  EXPECT_GT(s.field(0.7, 0, 0), 0);
  EXPECT_TRUE(s.inside(0.2, -0.3, 0.4));
  EXPECT_TRUE(s.inside(0.49, 0.49, 0.49));
  EXPECT_FALSE(s.inside(2, 2, 2));
}

TEST(Solid, PointsBeyondAClipPlaneAreOutside) {
  Params p = small_box_ball();
  p.mesh.clip = {{{0, 0, 2}, 0.2}};  // 2z <= 0.2, i.e. z <= 0.1 (the normal is normalised)
  const Solid s(p);
  EXPECT_TRUE(s.inside(0, 0, 0.05));
  EXPECT_FALSE(s.inside(0, 0, 0.15));
  EXPECT_FALSE(s.inside(0.3, -0.2, 0.3));
  EXPECT_TRUE(s.inside(0.3, -0.2, -0.3));
  EXPECT_GT(s.field(0, 0, 0.15), 0);
}

TEST(Solid, ConstraintIsTheSignedDistanceToTheBoxAndClips) {
  Params p = small_box_ball();
  EXPECT_NEAR(Solid(p).constraint(0, 0, 0), -0.5, 1e-15);
  EXPECT_NEAR(Solid(p).constraint(0.4, 0, 0), -0.1, 1e-15);
  EXPECT_NEAR(Solid(p).constraint(0.7, 0, 0), 0.2, 1e-15);
  EXPECT_NEAR(Solid(p).constraint(0, -0.8, 0.1), 0.3, 1e-15);
  p.mesh.clip = {{{0, 0, 2}, 0.2}};
  const Solid s(p);
  EXPECT_NEAR(s.constraint(0, 0, 0), -0.1, 1e-15);
  EXPECT_NEAR(s.constraint(0, 0, 0.3), 0.2, 1e-15);
  EXPECT_NEAR(s.constraint(0, 0, -0.3), -0.2, 1e-15);
  p.mesh.clip = {{{1, 1, 0}, 0}};  // x + y <= 0
  const Solid diagonal(p);
  EXPECT_NEAR(diagonal.constraint(0.1, 0.1, 0), 0.2 / std::sqrt(2.0), 1e-15);
}

TEST(Solid, InsideTheBoxAwayFromTheWallsTheFieldIsTheClassifiers) {
  Params p = make_params("h^2", Method::kEscape, 10, 1);
  p.bounds = {{-1.5, -1.5, -1.5}, {1.5, 1.5, 1.5}};
  const Solid s(p);
  for (const Point& q : random_points(2000, -1.2, 1.2, 13)) {
    const bool ball = q.x * q.x + q.y * q.y + q.z * q.z <= 1;
    if (std::abs(std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z) - 1) < 1e-12) continue;
    EXPECT_EQ(s.inside(q.x, q.y, q.z), ball);
    if (!ball) {
      EXPECT_EQ(s.field(q.x, q.y, q.z), s.classifier().field(q.x, q.y, q.z));
    }
  }
}

}  // namespace
}  // namespace qjulia
