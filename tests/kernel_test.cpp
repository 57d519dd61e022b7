// The batched vector kernel against the scalar reference, on every target this build dispatches
// to: random points of every preset and of randomly generated formulas.
#include "field/kernel.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "field/program.h"
#include "field/quat_functions.h"
#include "hwy/targets.h"
#include "qjulia/field/classify.h"
#include "qjulia/field/params.h"

namespace qjulia {
namespace {

// Quaternion arithmetic in two roundings of double precision: as the scalar path computes
// (kFused = false: separate products and sums, division by |a|^2), and as the vector kernel
// computes (kFused = true: fused multiply-adds in the same order, one reciprocal of |a|^2, and
// the analytic functions an ulp off in their argument).
// Where the two give different F, F depends on the last bits and no two correct evaluators
// need agree.
template <bool kFused>
struct Arith {
  static double madd(double a, double b, double c) {
    return kFused ? std::fma(a, b, c) : a * b + c;
  }
  static double nmadd(double a, double b, double c) {
    return kFused ? std::fma(-a, b, c) : c - a * b;
  }
  static double norm2(const Quat& a) {
    return madd(a.z, a.z, madd(a.y, a.y, madd(a.x, a.x, a.w * a.w)));
  }
  static Quat mul(const Quat& a, const Quat& b) {
    if (!kFused) return a * b;
    return {nmadd(a.z, b.z, nmadd(a.y, b.y, nmadd(a.x, b.x, a.w * b.w))),
            nmadd(a.z, b.y, madd(a.y, b.z, madd(a.x, b.w, a.w * b.x))),
            madd(a.z, b.x, madd(a.y, b.w, nmadd(a.x, b.z, a.w * b.y))),
            madd(a.z, b.w, nmadd(a.y, b.x, madd(a.x, b.y, a.w * b.z)))};
  }
  static Quat sqr(const Quat& a) {
    if (!kFused) return qjulia::sqr(a);
    const double t = a.w + a.w;
    return {nmadd(a.z, a.z, nmadd(a.y, a.y, nmadd(a.x, a.x, a.w * a.w))), t * a.x, t * a.y,
            t * a.z};
  }
  // The analytic functions are the scalar ones; the second rounding moves their argument by an
  // ulp, as the vector functions' own rounding does.
  static Quat arg(const Quat& a) {
    if (!kFused) return a;
    return {std::nextafter(a.w, INFINITY), std::nextafter(a.x, INFINITY),
            std::nextafter(a.y, INFINITY), std::nextafter(a.z, INFINITY)};
  }
  static Quat inv(const Quat& a) {
    if (!kFused) return qjulia::inv(a);
    const double r = 1.0 / norm2(a);
    return {a.w * r, -(a.x * r), -(a.y * r), -(a.z * r)};
  }
};

// The formula's compiled program in the arithmetic A.
template <class A>
Quat eval(const Formula::Program& p, const Quat& h, const std::vector<Quat>& constants) {
  using detail::OpCode;
  Quat r[detail::kRegisters];
  r[0] = h;
  for (std::size_t i = 0; i < p.used_index.size(); ++i) r[1 + i] = constants[p.used_index[i]];
  for (const detail::Op& op : p.ops) {
    const Quat a = r[op.a], b = r[op.b], l = op.lit;
    Quat v;
    switch (op.code) {
      case OpCode::kLoad:
        v = l;
        break;
      case OpCode::kNeg:
        v = -a;
        break;
      case OpCode::kConj:
        v = conj(a);
        break;
      case OpCode::kInv:
        v = A::inv(a);
        break;
      case OpCode::kNorm:
        v = Quat(A::norm2(a));
        break;
      case OpCode::kAbs:
        v = Quat(std::sqrt(A::norm2(a)));
        break;
      case OpCode::kSqr:
        v = A::sqr(a);
        break;
      case OpCode::kAdd:
        v = a + b;
        break;
      case OpCode::kSub:
        v = a - b;
        break;
      case OpCode::kMul:
        v = A::mul(a, b);
        break;
      case OpCode::kDiv:
        v = A::mul(a, A::inv(b));
        break;
      case OpCode::kAddReal:
        v = {a.w + l.w, a.x, a.y, a.z};
        break;
      case OpCode::kAddLit:
        v = a + l;
        break;
      case OpCode::kLitSub:
        v = l - a;
        break;
      case OpCode::kScale:
        v = l.w * a;
        break;
      case OpCode::kMulLit:
        v = A::mul(a, l);
        break;
      case OpCode::kLitMul:
        v = A::mul(l, a);
        break;
      case OpCode::kLitDiv:
        v = A::mul(l, A::inv(a));
        break;
      case OpCode::kScaleAddReal:
        v = l.w * a;
        v.w += l.x;
        break;
      case OpCode::kExp:
        v = detail::qexp(A::arg(a));
        break;
      case OpCode::kLog:
        v = detail::qlog(A::arg(a));
        break;
      case OpCode::kSqrt:
        v = detail::qsqrt(A::arg(a));
        break;
      case OpCode::kSin:
        v = detail::qsin(A::arg(a));
        break;
      case OpCode::kCos:
        v = detail::qcos(A::arg(a));
        break;
      case OpCode::kTan:
        v = detail::qtan(A::arg(a));
        break;
      case OpCode::kSinh:
        v = detail::qsinh(A::arg(a));
        break;
      case OpCode::kCosh:
        v = detail::qcosh(A::arg(a));
        break;
      case OpCode::kTanh:
        v = detail::qtanh(A::arg(a));
        break;
      case OpCode::kPowReal:
        v = detail::qpow(A::arg(a), l.w);
        break;
    }
    r[op.dst] = v;
  }
  return r[p.result];
}

// F of docs/design.md in the arithmetic of Arith<kFused>: the reference the kernel is held to
// (kFused = false, the scalar path's arithmetic), and the check of how well F is conditioned.
template <bool kFused>
double reference_field(const Params& p, double x, double y, double z) {
  std::vector<std::string> names;
  std::vector<Quat> values;
  for (const auto& [name, value] : p.constants) {
    names.push_back(name);
    values.push_back(value);
  }
  int c_index = -1;
  if (p.mode == Mode::kMandelbrot) {
    c_index = static_cast<int>(names.size());
    for (std::size_t i = 0; i < names.size(); ++i)
      if (names[i] == "c") c_index = static_cast<int>(i);
    if (c_index == static_cast<int>(names.size())) {
      names.push_back("c");
      values.push_back({});
    }
  }
  const Formula f = Formula::compile(p.formula, names);
  const Slice::General s = p.slice.resolved();
  const Quat q = s.origin + x * s.directions[0] + y * s.directions[1] + z * s.directions[2];
  using T = double;
  using A = Arith<kFused>;
  Quat h = q;
  if (c_index >= 0) {
    values[c_index] = q;
    h = p.start;
  }
  const int n = p.iterations;
  const T log_r = std::log(p.bailout);
  const T r2 = p.bailout * p.bailout;
  const T inf = std::numeric_limits<T>::infinity();
  auto frac = [](T a, T b) -> T {
    if (std::isinf(a)) return std::isinf(b) ? 0.5 : 1.0;
    if (std::isinf(b)) return 0.0;
    return a / (a + b);
  };
  auto clamp = [](T v) -> double {
    return std::isnan(v) ? 1e6 : static_cast<double>(std::max<T>(-1e6, std::min<T>(1e6, v)));
  };
  const T half = 0.5;
  if (p.method == Method::kEscape) {
    T prev2 = A::norm2(h);
    if (prev2 > r2) return clamp(n + frac(half * std::log(prev2) - log_r, 1.0));
    for (int k = 1; k <= n; ++k) {
      const Quat next = eval<A>(f.program(), h, values);
      const T n2 = A::norm2(next);
      if (!(n2 <= r2)) {
        const T sv = std::isfinite(n2) ? half * std::log(n2) - log_r : inf;
        const T sp = prev2 > 0 ? half * std::log(prev2) - log_r : -1.0;
        return clamp((n - k) + frac(sv, -sp));
      }
      h = next;
      prev2 = n2;
    }
    return clamp(half * std::log(prev2) - log_r);
  }
  T t_prev = inf;
  for (int k = 1; k <= n; ++k) {
    const Quat next = eval<A>(f.program(), h, values);
    const T d2 = A::norm2(next - h);
    if (!std::isfinite(d2)) return -1e6;
    const T t = d2 > 0 ? half * std::log(d2) - log_r : -inf;
    if (t < 0) return clamp(k == 1 ? (n - 1) + frac(-t, 1.0) : (n - k) + frac(-t, t_prev));
    t_prev = t;
    h = next;
  }
  return clamp(-t_prev);
}

// A random number of [lo, hi) as a formula writes it, with three decimals.
std::string random_literal(std::mt19937_64& rng, double lo, double hi) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", std::uniform_real_distribution<double>(lo, hi)(rng));
  return buf;
}

// Random expressions in h and the constants over the whole language the kernel covers.
std::string random_formula(std::mt19937_64& rng, int depth) {
  std::uniform_int_distribution<int> pick(0, depth <= 0 ? 3 : 14);
  auto signed_number = [&] { return random_literal(rng, -1.5, 1.5); };
  auto number = [&] {
    const std::string s = signed_number();
    return s[0] == '-' ? "(" + s + ")" : s;
  };
  switch (pick(rng)) {
    case 0:
    case 1:
      return "h";
    case 2:
      return "c";
    case 3:
      if (std::uniform_int_distribution<int>(0, 1)(rng)) return number();
      return "[" + signed_number() + "," + signed_number() + "," + signed_number() + "," +
             signed_number() + "]";
    case 4:
      return "(" + random_formula(rng, depth - 1) + "+" + random_formula(rng, depth - 1) + ")";
    case 5:
      return "(" + random_formula(rng, depth - 1) + "-" + random_formula(rng, depth - 1) + ")";
    case 6:
    case 7:
      return "(" + random_formula(rng, depth - 1) + "*" + random_formula(rng, depth - 1) + ")";
    case 8:
      return "(" + random_formula(rng, depth - 1) + "/" + random_formula(rng, depth - 1) + ")";
    case 9: {
      const int e = std::uniform_int_distribution<int>(-3, 4)(rng);
      return "(" + random_formula(rng, depth - 1) + ")^" + std::to_string(e);
    }
    case 10:
      return "-" + random_formula(rng, depth - 1);
    case 11: {
      static const char* const e[] = {"0.5", "-0.5", "1.5", "-1.5", "2.5"};
      return "(" + random_formula(rng, depth - 1) + ")^" +
             e[std::uniform_int_distribution<int>(0, 4)(rng)];
    }
    default: {
      static const char* const f[] = {"conj", "inv", "norm", "abs", "sqr",  "exp",  "log",
                                      "sqrt", "sin", "cos",  "tan", "sinh", "cosh", "tanh"};
      return std::string(f[std::uniform_int_distribution<int>(0, 13)(rng)]) + "(" +
             random_formula(rng, depth - 1) + ")";
    }
  }
}

// Random points of p's box: F by the reference, and whether it is well-conditioned there (the
// reference computed with the kernel's rounding agrees within 1e-11 * max(1, |F|)).
struct BoxSample {
  std::vector<double> x, y, z, f;
  std::vector<char> conditioned;
  int excluded = 0;
};

// Appends `count` random points of p's box to x, y, z.
void add_random_points(const Params& p, int count, std::mt19937_64& rng, std::vector<double>& x,
                       std::vector<double>& y, std::vector<double>& z) {
  auto in = [&](int axis) {
    return std::uniform_real_distribution<double>(p.bounds.min[axis], p.bounds.max[axis])(rng);
  };
  for (int i = 0; i < count; ++i) {
    x.push_back(in(0));
    y.push_back(in(1));
    z.push_back(in(2));
  }
}

BoxSample sample_box(const Params& p, int count, unsigned seed) {
  std::mt19937_64 rng(seed);
  BoxSample s;
  add_random_points(p, count, rng, s.x, s.y, s.z);
  for (int i = 0; i < count; ++i) {
    const double f = reference_field<false>(p, s.x[i], s.y[i], s.z[i]);
    const double fused = reference_field<true>(p, s.x[i], s.y[i], s.z[i]);
    const bool conditioned = std::abs(fused - f) <= 1e-11 * std::max(1.0, std::abs(f));
    s.f.push_back(f);
    s.conditioned.push_back(conditioned);
    s.excluded += !conditioned;
  }
  return s;
}

// Runs the kernel for `p` over `count` random points of its box (sample_box) on every vector
// target it is compiled for and this CPU runs (F, or the refinement values with `root`), and
// calls agree(target, sample, i, value) at each well-conditioned point until it returns false.
// Returns the sample; none when the kernel does not cover p (a failure).
template <class Agree>
BoxSample on_every_target(const Params& p, int count, unsigned seed, bool root, Agree&& agree) {
  const Classifier cls(p);
  const detail::KernelSetup* k = cls.kernel();
  EXPECT_NE(k, nullptr) << p.formula << ": the kernel should cover this formula";
  if (!k) return {};
  const BoxSample s = sample_box(p, count, seed);
  std::vector<double> got(s.x.size());
  for (std::int64_t target : detail::kernel_dispatch_targets()) {
    hwy::SetSupportedTargetsForTest(target);
    std::fill(got.begin(), got.end(), std::nan(""));
    detail::kernel_field(*k, s.x.data(), s.y.data(), s.z.data(), s.x.size(), got.data(), root);
    for (std::size_t i = 0; i < got.size(); ++i)
      if (s.conditioned[i] && !agree(target, s, i, got[i])) break;
  }
  hwy::SetSupportedTargetsForTest(0);
  return s;
}

// Whether the kernel's value g at point i of the sample agrees with `want` (the `what` value):
// the same sign where |want| > sign_floor, and within rel * max(1, |want|). A failure names the
// target, the map and the point.
bool agrees(std::int64_t target, const Params& p, const BoxSample& s, std::size_t i, double g,
            double want, double sign_floor, double rel, const char* what) {
  const bool same_sign = std::abs(want) <= sign_floor || (want <= 0) == (g <= 0);
  const bool close = std::abs(g - want) <= rel * std::max(1.0, std::abs(want));
  EXPECT_TRUE(same_sign && close) << hwy::TargetName(target) << " '" << p.formula << "' "
                                  << to_string(p.method) << " at (" << s.x[i] << ", " << s.y[i]
                                  << ", " << s.z[i] << "): kernel " << g << ", " << what << " "
                                  << want;
  return same_sign && close;
}

// Runs `p` through the kernel on every vector target it is compiled for and this CPU runs,
// against the reference, on random points of the box. The kernel uses
// fused multiply-adds and the reference does not, so the two differ in the last bits; F must
// agree within 1e-9 * max(1, |F|), with the same classification where |F| > 1e-9, at every point
// where F is well-conditioned: where the reference computed with the kernel's rounding (fused
// multiply-adds, a reciprocal) agrees with it within 1e-11 * max(1, |F|). Elsewhere (an orbit
// whose last step is rounding noise, as in h/h) no two correct evaluators need agree. Returns
// the share of points so excluded.
double check_against_reference(const Params& p, int count, unsigned seed) {
  const BoxSample s = on_every_target(
      p, count, seed, false, [&](std::int64_t target, const BoxSample& s, std::size_t i, double g) {
        return agrees(target, p, s, i, g, s.f[i], 1e-9, 1e-9, "reference");
      });
  return s.x.empty() ? 1.0 : static_cast<double>(s.excluded) / count;
}

TEST(Kernel, DispatchesToAVX2OrBetterWhereTheCpuHasIt) {
  const std::vector<std::string> targets = detail::kernel_targets();
  EXPECT_EQ(detail::kernel_dispatch_targets().size(), targets.size());
  if (__builtin_cpu_supports("avx2")) {
    ASSERT_FALSE(targets.empty());
    EXPECT_NE(detail::kernel_target(), "scalar");
    EXPECT_EQ(Classifier(preset("classic-julia")).evaluator(), detail::kernel_target());
  }
  if (__builtin_cpu_supports("avx512f")) {
    EXPECT_EQ(detail::kernel_target(), "AVX3");
  }
}

TEST(Kernel, EveryPresetMatchesTheScalarReferenceOnEveryTarget) {
  unsigned seed = 1;
  for (const std::string& name : preset_names()) {
    SCOPED_TRACE(name);
    EXPECT_LT(check_against_reference(preset(name), 4000, seed++), 0.01);
  }
}

// The float output (what Classifier::field writes) is the double output rounded to float, bit
// for bit, for F and the refinement value, on every target: random points of each preset's box
// plus points where metrics are 0 or the orbit meets a pole (the special cases' path), in
// batches of odd lengths (the finished orbits are padded to a pair of vectors).
TEST(Kernel, TheFloatOutputIsTheDoubleOutputRounded) {
  std::mt19937_64 rng(20261207);
  for (const std::string& name : preset_names()) {
    SCOPED_TRACE(name);
    const Params p = preset(name);
    const Classifier cls(p);
    const detail::KernelSetup* k = cls.kernel();
    ASSERT_NE(k, nullptr);
    std::vector<double> x, y, z;
    for (double v : {0.0, 1.0, -1.0, 0.5}) {  // on the axes: zero and pole orbits
      x.push_back(v);
      y.push_back(0);
      z.push_back(0);
    }
    add_random_points(p, 2997, rng, x, y, z);
    for (std::int64_t target : detail::kernel_dispatch_targets()) {
      hwy::SetSupportedTargetsForTest(target);
      for (bool root : {false, true})
        for (std::size_t n : {x.size(), std::size_t{1}, std::size_t{13}, std::size_t{1001}}) {
          std::vector<double> wide(n, std::nan(""));
          std::vector<float> narrow(n, std::nanf(""));
          const auto steps =
              detail::kernel_field(*k, x.data(), y.data(), z.data(), n, wide.data(), root);
          EXPECT_EQ(detail::kernel_field(*k, x.data(), y.data(), z.data(), n, narrow.data(), root),
                    steps);
          int wrong = 0;
          for (std::size_t i = 0; i < n; ++i) {
            const float want = static_cast<float>(wide[i]);
            std::uint32_t a, b;
            std::memcpy(&a, &want, 4);
            std::memcpy(&b, &narrow[i], 4);
            if (a != b && wrong++ < 3)
              ADD_FAILURE() << hwy::TargetName(target) << (root ? " root" : " F") << " n=" << n
                            << " at " << i << ": " << narrow[i] << " against " << want;
          }
          EXPECT_EQ(wrong, 0);
        }
    }
    hwy::SetSupportedTargetsForTest(0);
  }
}

// An axis-aligned slice's points by additions (KernelSetup::axis_slice) give the values of the
// fused form, bit for bit: every preset, and h^2 + c and h^1.5 + c (whose logarithm tells the
// sign of a zero) under other axis orders and fixed values of either sign (a negative one, or
// -0, makes origin components -0), at random points of the box and at points whose
// coordinates are +-0 and +-0.5, on every target, F and the refinement value.
TEST(Kernel, AnAxisAlignedSliceByAdditionsGivesTheFusedFormsValues) {
  std::mt19937_64 rng(20261207);
  std::vector<Params> cases;
  for (const std::string& name : preset_names()) cases.push_back(preset(name));
  for (const char* name : {"classic-julia", "power-screw"})
    for (const char* axes : {"rmn", "nmr", "pnm", "mrp"})
      for (double fixed : {0.0, 0.3, -0.25, -0.0}) {
        Params p = preset(name);
        p.slice.axes = axes;
        p.slice.fixed = fixed;
        cases.push_back(p);
      }
  int by_additions = 0;
  for (const Params& p : cases) {
    SCOPED_TRACE(p.formula + " axes " + p.slice.axes + " fixed " + std::to_string(p.slice.fixed) +
                 (std::signbit(p.slice.fixed) ? " (negative)" : ""));
    const Classifier cls(p);
    const detail::KernelSetup* k = cls.kernel();
    ASSERT_NE(k, nullptr);
    by_additions += k->axis_slice;
    detail::KernelSetup fused = *k;
    fused.axis_slice = false;
    std::vector<double> x, y, z;
    const double special[4] = {0.0, -0.0, 0.5, -0.5};
    for (double a : special)
      for (double b : special)
        for (double c : special) {
          x.push_back(a);
          y.push_back(b);
          z.push_back(c);
        }
    add_random_points(p, 1000, rng, x, y, z);
    for (std::int64_t target : detail::kernel_dispatch_targets()) {
      hwy::SetSupportedTargetsForTest(target);
      for (bool root : {false, true}) {
        std::vector<double> got(x.size()), want(x.size());
        detail::kernel_field(*k, x.data(), y.data(), z.data(), x.size(), got.data(), root);
        detail::kernel_field(fused, x.data(), y.data(), z.data(), x.size(), want.data(), root);
        int wrong = 0;
        for (std::size_t i = 0; i < x.size(); ++i)
          if (std::memcmp(&got[i], &want[i], sizeof(double)) != 0 && wrong++ < 3)
            ADD_FAILURE() << hwy::TargetName(target) << (root ? " root" : " F") << " at (" << x[i]
                          << ", " << y[i] << ", " << z[i] << "): " << got[i] << " against "
                          << want[i];
        EXPECT_EQ(wrong, 0);
      }
    }
    hwy::SetSupportedTargetsForTest(0);
  }
  // The additions must have been taken: every axis-aligned case above.
  EXPECT_EQ(by_additions, static_cast<int>(cases.size()));
}

TEST(Kernel, RandomFormulasMatchTheScalarReferenceOnEveryTarget) {
  std::mt19937_64 rng(20261201);
  double excluded = 0;
  const int trials = 200;
  for (int trial = 0; trial < trials; ++trial) {
    Params p;
    p.formula = random_formula(rng, 3);
    p.set_constant("c", {0.3, -0.4, 0.2, 0.1});
    p.method = trial % 2 ? Method::kEscape : Method::kCutoff;
    p.mode = trial % 5 == 4 ? Mode::kMandelbrot : Mode::kJulia;
    p.iterations = 3 + trial % 8;
    p.bailout = p.method == Method::kEscape ? 2.5 : 0.05;
    SCOPED_TRACE(p.formula);
    excluded += check_against_reference(p, 300, 1000 + trial);
  }
  // The comparison must cover the points, not skip them.
  EXPECT_LT(excluded / trials, 0.05);
}

// h^2 plus nothing, c, a real number or a quaternion, and a real factor of h^2 plus a number
// or c: the programs of one operation, which each vector target runs through a register-resident
// loop (refills of decided lanes included), in both methods and both modes, with 4 to 12
// iterations: f(p, trial) for each (trial 0 .. 23).
template <class F>
void each_single_operation_map(F&& f) {
  const char* const formulas[] = {
      "h^2", "h^2 + c", "h^2 - 0.8", "h^2 + [0.1,-0.6,0.2,0.05]", "2*h^2 - 0.8", "0.5*h^2 + c"};
  int trial = 0;
  for (const char* formula : formulas)
    for (Method method : {Method::kEscape, Method::kCutoff})
      for (Mode mode : {Mode::kJulia, Mode::kMandelbrot}) {
        Params p;
        p.formula = formula;
        p.set_constant("c", {-0.2, 0.8, 0.0, 0.0});
        p.method = method;
        p.mode = mode;
        p.iterations = 4 + trial % 9;
        p.bailout = method == Method::kEscape ? 4.0 : 0.05;
        SCOPED_TRACE(std::string(formula) + " " + to_string(method) +
                     (mode == Mode::kMandelbrot ? " Mandelbrot" : " Julia"));
        f(p, trial++);
      }
}

TEST(Kernel, SingleOperationMapsMatchTheScalarReferenceOnEveryTarget) {
  // Over boxes where orbits end at every step; 997 points: the last vector of every target is
  // partly filled.
  each_single_operation_map([](const Params& p, int trial) {
    EXPECT_LT(check_against_reference(p, 997, 500 + trial), 0.02);
  });
}

// The refinement values (Orbit::root: the extreme of the orbit's metric up to its decision) of
// the kernel on every vector target against the scalar classifier's, at random points of the box
// where F is well-conditioned (as check_against_reference): the same sign where |root| > 1e-6,
// and within 1e-5 * max(1, |root|) (the scalar value is a float). Returns the points compared.
int check_roots_against_scalar(const Params& p, int count, unsigned seed) {
  const Classifier cls(p);
  const BoxSample s = on_every_target(
      p, count, seed, true, [&](std::int64_t target, const BoxSample& s, std::size_t i, double g) {
        return agrees(target, p, s, i, g, cls.orbit(s.x[i], s.y[i], s.z[i]).root, 1e-6, 1e-5,
                      "scalar");
      });
  return static_cast<int>(s.x.size()) - s.excluded;
}

TEST(Kernel, RefinementValuesMatchTheScalarOnesOnEveryTarget) {
  // The single-operation maps (whose loops keep the extreme only for these values) and every
  // preset.
  each_single_operation_map([](const Params& p, int trial) {
    EXPECT_GT(check_roots_against_scalar(p, 997, 700 + trial), 900);
  });
  unsigned seed = 800;
  for (const std::string& name : preset_names()) {
    SCOPED_TRACE(name);
    EXPECT_GT(check_roots_against_scalar(preset(name), 2000, seed++), 1900);
  }
}

// Newton's maps of cubics, (s1 h^3 + a) / (s2 h^2), which AVX-512 and AVX2 run in a register
// loop of their own: both methods, 4 to 12 iterations, over newton-cubic's box: f(p, trial) for
// each (trial 0 .. 7).
template <class F>
void each_cubic_over_square_map(F&& f) {
  const char* const formulas[] = {"(2*h^3+1)/(3*h^2)", "(h^3 - 0.7)/h^2", "(0.5*h^3+2)/(1.5*h^2)",
                                  "(3*h^3+2)/(4*h^2)"};
  int trial = 0;
  for (const char* formula : formulas)
    for (Method method : {Method::kEscape, Method::kCutoff}) {
      Params p = preset("newton-cubic");
      p.formula = formula;
      p.method = method;
      p.iterations = 4 + trial;
      p.bailout = method == Method::kEscape ? 2.0 : 0.01;
      SCOPED_TRACE(std::string(formula) + " " + to_string(method));
      f(p, trial++);
    }
}

TEST(Kernel, CubicOverSquareMapsMatchTheScalarReferenceOnEveryTarget) {
  // F against the reference and the refinement values against the scalar classifier; 997
  // points: the last vector of every target is partly filled.
  each_cubic_over_square_map([](const Params& p, int trial) {
    EXPECT_LT(check_against_reference(p, 997, 900 + trial), 0.02);
    EXPECT_GT(check_roots_against_scalar(p, 997, 950 + trial), 900);
  });
}

// A random map of one of the forms the register loops take, and the loops it may take on
// AVX-512 and AVX2: s h^2 + q (the square loop without a factor, a chain with one), Newton's
// (s h^3 + a) / (t h^2), or one to three operations with literal operands, each on the one
// before (a chain, or the square loop when that is a square and an addition). Literals are
// random; a factor is left out, random, or a written 1 (a factor of 1 fused into the square
// leaves it to the square loop).
struct ShapedMap {
  std::string formula;
  std::vector<detail::KernelLoop> julia, mandelbrot;  // the loops it may take in each mode
};

ShapedMap random_register_map(std::mt19937_64& rng) {
  using L = detail::KernelLoop;
  auto real = [&](double lo, double hi) { return random_literal(rng, lo, hi); };
  auto quat = [&] {
    return "[" + real(-0.8, 0.8) + "," + real(-0.8, 0.8) + "," + real(-0.8, 0.8) + "," +
           real(-0.8, 0.8) + "]";
  };
  auto pick = [&](int n) { return std::uniform_int_distribution<int>(0, n - 1)(rng); };
  // A factor: 0 left out, 1 written as 1, 2 random (positive).
  auto factor = [&](std::string* text) {
    const int k = pick(3);
    *text = k == 0 ? "" : k == 1 ? "1*" : real(0.3, 2.5) + "*";
    return k;
  };
  ShapedMap m;
  switch (pick(3)) {
    case 0: {
      std::string s;
      const int k = factor(&s);
      static const char* const kinds[] = {"", " + c", " - c", " + R", " + Q"};
      const int kind = pick(5);
      std::string q = kinds[kind];
      if (kind == 3) q = " + " + real(-1.2, 0.6);
      if (kind == 4) q = " + " + quat();
      m.formula = s + "h^2" + q;
      m.julia = {k < 2 ? L::kSquare : L::kChain};
      m.mandelbrot = m.julia;
      // c differs from lane to lane: only the square loop adds it (and does not subtract it).
      if (kind == 1 || kind == 2) m.mandelbrot = {k < 2 && kind == 1 ? L::kSquare : L::kSweeps};
      break;
    }
    case 1: {
      std::string s, t;
      factor(&s);
      factor(&t);
      m.formula = "(" + s + "h^3 " + (pick(2) ? "+ " : "- ") + real(0.1, 2.0) + ")/(" + t + "h^2)";
      m.julia = m.mandelbrot = {L::kCubicOverSquare};
      break;
    }
    default: {
      static const char* const links[] = {
          "sqr(X)",  "(X)^2",   "-(X)",    "conj(X)", "inv(X)",  "(X) + R",    "(X) + Q",
          "R*(X)",   "(X)*Q",   "Q*(X)",   "exp(X)",  "log(X)",  "sin(X)",     "cos(X)",
          "sqrt(X)", "tanh(X)", "sinh(X)", "cosh(X)", "(X)^1.5", "R*(X)^2 + R"};
      std::string f = "h";
      for (int n = 1 + pick(3); n > 0; --n) {
        std::string out;
        for (char ch : std::string(links[pick(20)])) {
          if (ch == 'X')
            out += f;
          else if (ch == 'R')
            out += real(0.3, 1.5);
          else if (ch == 'Q')
            out += quat();
          else
            out += ch;
        }
        f = out;
      }
      m.formula = f;
      m.julia = m.mandelbrot = {L::kChain, L::kSquare};  // a square and an addition alone
    }
  }
  return m;
}

TEST(Kernel, RandomMapsOfTheRegisterLoopsTakeThemAndMatchTheScalarReference) {
  std::mt19937_64 rng(20261206);
  double excluded = 0;
  const int trials = 120;
  int roots = 0;
  for (int trial = 0; trial < trials; ++trial) {
    const ShapedMap m = random_register_map(rng);
    Params p;
    p.formula = m.formula;
    p.set_constant("c", {-0.2, 0.8, 0.1, 0.0});
    p.method = trial % 2 ? Method::kEscape : Method::kCutoff;
    p.mode = trial % 4 == 3 ? Mode::kMandelbrot : Mode::kJulia;
    p.iterations = 3 + trial % 9;
    p.bailout = p.method == Method::kEscape ? 2.5 : 0.05;
    SCOPED_TRACE(p.formula + " " + to_string(p.method) +
                 (p.mode == Mode::kMandelbrot ? " Mandelbrot" : " Julia"));
    const std::vector<detail::KernelLoop>& may =
        p.mode == Mode::kMandelbrot ? m.mandelbrot : m.julia;
    const Classifier cls(p);
    ASSERT_NE(cls.kernel(), nullptr);
    for (std::int64_t target : detail::kernel_dispatch_targets()) {
      hwy::SetSupportedTargetsForTest(target);
      const detail::KernelLoop loop = detail::kernel_loop(*cls.kernel());
      EXPECT_TRUE(std::find(may.begin(), may.end(), loop) != may.end())
          << hwy::TargetName(target) << " runs it in " << detail::to_string(loop);
    }
    hwy::SetSupportedTargetsForTest(0);
    excluded += check_against_reference(p, 301, 3000 + trial);
    roots += check_roots_against_scalar(p, 301, 4000 + trial);
  }
  // The comparisons must cover the points, not skip them.
  EXPECT_LT(excluded / trials, 0.05);
  EXPECT_GT(roots, 0.9 * 301 * trials);
}

TEST(Kernel, AnalyticFunctionsMatchTheScalarOnesOnEveryTarget) {
  // Per component within 1e-12 * max(1, |f|), at points at least 1e-6 from the branch cut (the
  // negative real axis, for log, sqrt and real powers), with magnitudes from tiny to those that
  // send lanes to the scalar path.
  using detail::OpCode;
  std::mt19937_64 rng(3);
  std::vector<Quat> in;
  for (int i = 0; i < 20000; ++i) {
    const double scale = std::pow(10.0, std::uniform_real_distribution<double>(-8, 3)(rng));
    std::normal_distribution<double> g(0, 1);
    Quat q(scale * g(rng), scale * g(rng), scale * g(rng), scale * g(rng));
    if (i % 10 == 0) q.x = q.y = q.z = 0;  // real points (t = 0): u = i
    const double t = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
    if (q.w < 0 && t < 1e-6) q.w = -q.w;  // away from the cut
    in.push_back(q);
  }
  in.push_back(Quat(0.5, 800, 0, 0));  // beyond the vector sin/cos range: the scalar path
  in.push_back(Quat(750, 0.1, 0, 0));  // exp overflows
  in.push_back(Quat(0, 0, 0, 0));
  const OpCode codes[] = {OpCode::kExp,  OpCode::kLog,     OpCode::kSqrt,   OpCode::kSin,
                          OpCode::kCos,  OpCode::kTan,     OpCode::kSinh,   OpCode::kCosh,
                          OpCode::kTanh, OpCode::kPowReal, OpCode::kPowReal};
  const double exponents[] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 1.5, -0.5};
  for (std::int64_t target : detail::kernel_dispatch_targets()) {
    hwy::SetSupportedTargetsForTest(target);
    for (int c = 0; c < 11; ++c) {
      const std::vector<Quat> got = detail::kernel_analytic(codes[c], in, exponents[c]);
      int bad = 0;
      for (std::size_t i = 0; i < in.size() && bad < 3; ++i) {
        Quat want;
        switch (codes[c]) {
          case OpCode::kExp:
            want = detail::qexp(in[i]);
            break;
          case OpCode::kLog:
            want = detail::qlog(in[i]);
            break;
          case OpCode::kSqrt:
            want = detail::qsqrt(in[i]);
            break;
          case OpCode::kSin:
            want = detail::qsin(in[i]);
            break;
          case OpCode::kCos:
            want = detail::qcos(in[i]);
            break;
          case OpCode::kTan:
            want = detail::qtan(in[i]);
            break;
          case OpCode::kSinh:
            want = detail::qsinh(in[i]);
            break;
          case OpCode::kCosh:
            want = detail::qcosh(in[i]);
            break;
          case OpCode::kTanh:
            want = detail::qtanh(in[i]);
            break;
          default:
            want = detail::qpow(in[i], exponents[c]);
            break;
        }
        const double m = std::max(1.0, abs(want));
        for (int k = 0; k < 4; ++k) {
          const bool same_inf = std::isinf(want[k]) && want[k] == got[i][k];
          const bool both_nan = std::isnan(want[k]) && std::isnan(got[i][k]);
          if (!(std::abs(got[i][k] - want[k]) <= 1e-12 * m || same_inf || both_nan)) {
            ADD_FAILURE() << hwy::TargetName(target) << " code " << c << " at (" << in[i].w << ", "
                          << in[i].x << ", " << in[i].y << ", " << in[i].z << ") component " << k
                          << ": " << got[i][k] << " vs " << want[k];
            ++bad;
            break;
          }
        }
      }
    }
  }
  hwy::SetSupportedTargetsForTest(0);
}

TEST(Kernel, AnalyticFunctionsMatchTheScalarOnesAtTheExtremesAndOnTheNegativeRealAxis) {
  // The same tolerance on a grid of real parts and vector-part sizes from 1e-300 to 1e300 (the
  // scaled |v|, the overflow edges of exp, sin, sinh, the ends of the vector ranges), exact
  // negative reals (t = 0: u = i, so log, sqrt and real powers give the complex value in both
  // paths), vector parts down to 1e-300 on a negative real part (whose axis both paths keep:
  // the kernel hands a vector part whose |v|^2 is not a normal number to the scalar path),
  // non-finite input, and more exponents.
  using detail::OpCode;
  const double inf = std::numeric_limits<double>::infinity(), nan = std::nan("");
  std::vector<Quat> in;
  for (double a : {-1e300, -1e200, -1e150, -800.0, -710.0, -4.0, -1.0, -1e-300, 0.0, 1e-300, 1.0,
                   1.5707963267948966, 709.7, 709.9, 710.5, 1e150, 1e300})
    for (double t : {0.0, 1e-300, 1e-200, 1e-6, 1.0, 1.5707963267948966, 3.9e4, 4e4, 709.9, 711.0,
                     1e150, 1e300}) {
      in.push_back(Quat(a, t, 0, 0));
      in.push_back(Quat(a, 0.6 * t, -0.8 * t, 0));
    }
  for (const Quat& q : {Quat(inf, 0, 0, 0), Quat(-inf, 0, 0, 0), Quat(nan, 0, 0, 0),
                        Quat(0, inf, 0, 0), Quat(1, 0, nan, 0)})
    in.push_back(q);
  struct Case {
    OpCode code;
    double exponent;
    Quat (*f)(const Quat&);
  };
  const Case cases[] = {{OpCode::kExp, 0, detail::qexp},   {OpCode::kLog, 0, detail::qlog},
                        {OpCode::kSqrt, 0, detail::qsqrt}, {OpCode::kSin, 0, detail::qsin},
                        {OpCode::kCos, 0, detail::qcos},   {OpCode::kTan, 0, detail::qtan},
                        {OpCode::kSinh, 0, detail::qsinh}, {OpCode::kCosh, 0, detail::qcosh},
                        {OpCode::kTanh, 0, detail::qtanh}, {OpCode::kPowReal, 0.5, nullptr},
                        {OpCode::kPowReal, -0.5, nullptr}, {OpCode::kPowReal, 1.5, nullptr},
                        {OpCode::kPowReal, -1.5, nullptr}, {OpCode::kPowReal, 2.5, nullptr},
                        {OpCode::kPowReal, 7.3, nullptr},  {OpCode::kPowReal, -63.5, nullptr},
                        {OpCode::kPowReal, 1e-3, nullptr}};
  for (std::int64_t target : detail::kernel_dispatch_targets()) {
    hwy::SetSupportedTargetsForTest(target);
    for (const Case& c : cases) {
      const std::vector<Quat> got = detail::kernel_analytic(c.code, in, c.exponent);
      int bad = 0;
      for (std::size_t i = 0; i < in.size() && bad < 3; ++i) {
        const Quat want = c.f ? c.f(in[i]) : detail::qpow(in[i], c.exponent);
        const double m = std::max(1.0, abs(want));
        for (int k = 0; k < 4; ++k) {
          const bool same_inf = std::isinf(want[k]) && want[k] == got[i][k];
          const bool both_nan = std::isnan(want[k]) && std::isnan(got[i][k]);
          if (!(std::abs(got[i][k] - want[k]) <= 1e-12 * m || same_inf || both_nan)) {
            ADD_FAILURE() << hwy::TargetName(target) << " code " << static_cast<int>(c.code)
                          << " (exponent " << c.exponent << ") at (" << in[i].w << ", " << in[i].x
                          << ", " << in[i].y << ", " << in[i].z << ") component " << k << ": "
                          << got[i][k] << " vs " << want[k];
            ++bad;
            break;
          }
        }
      }
    }
  }
  hwy::SetSupportedTargetsForTest(0);
}

TEST(Kernel, VectorsMixingSpecialAndOrdinaryOrbitsGiveEachOrbitItsOwnValue) {
  // F and the refinement values of a vector whose metrics are all positive normal numbers skip
  // the special cases' tests; one lane with a special metric sends its whole vector the long
  // way. Both ways must give every ordinary orbit the same value, and the special one its own,
  // wherever it sits in its vector. Special orbits: newton-cubic's pole at 0 (an infinite
  // metric) and its exact fixed point 1 (a step of length 0), and h^2 + 5 from 0 (it escapes at
  // its first step, from a previous iterate of norm 0).
  Params escape;
  escape.formula = "h^2 + 5";
  escape.method = Method::kEscape;
  escape.bailout = 4;
  escape.iterations = 10;
  struct Special {
    std::array<double, 3> at;  // slice coordinates
    int exit_step;             // of its orbit (-1 at a pole)
    bool pole;                 // F is -limit
  };
  struct Case {
    Params p;
    std::vector<Special> special;
  };
  const std::vector<Case> cases = {
      {preset("newton-cubic"), {{{0, 0, 0}, -1, true}, {{1, 0, 0}, 1, false}}},
      {escape, {{{0, 0, 0}, 1, false}}}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.p.formula);
    const Classifier cls(c.p);
    const detail::KernelSetup* k = cls.kernel();
    ASSERT_NE(k, nullptr);
    std::mt19937_64 rng(99);
    std::uniform_real_distribution<double> u(-1.2, 1.2);
    constexpr int kOrdinary = 23;
    std::vector<double> ox(kOrdinary), oy(kOrdinary), oz(kOrdinary);
    for (int i = 0; i < kOrdinary; ++i) ox[i] = u(rng), oy[i] = u(rng), oz[i] = u(rng);
    for (const Special& special : c.special) {
      const std::array<double, 3>& sp = special.at;
      // The orbit is the special one meant: a pole, or a step from or to a point of norm 0.
      const Orbit o = cls.orbit(sp[0], sp[1], sp[2]);
      EXPECT_EQ(o.exit_step, special.exit_step);
      EXPECT_EQ(o.field == -1e6f, special.pole) << "F " << o.field;
      if (!special.pole) {
        EXPECT_TRUE(c.p.method == Method::kEscape
                        ? norm2(cls.to_quaternion(sp[0], sp[1], sp[2])) == 0
                        : norm2(o.last - cls.to_quaternion(sp[0], sp[1], sp[2])) == 0);
      }
      for (std::int64_t target : detail::kernel_dispatch_targets()) {
        hwy::SetSupportedTargetsForTest(target);
        SCOPED_TRACE(hwy::TargetName(target));
        for (bool root : {false, true}) {
          std::vector<double> alone(kOrdinary), special_alone(1);
          detail::kernel_field(*k, ox.data(), oy.data(), oz.data(), kOrdinary, alone.data(), root);
          detail::kernel_field(*k, &sp[0], &sp[1], &sp[2], 1, special_alone.data(), root);
          for (int at = 0; at <= 8; ++at) {  // the special point at each lane of a vector
            std::vector<double> x(ox), y(oy), z(oz);
            x.insert(x.begin() + at, sp[0]);
            y.insert(y.begin() + at, sp[1]);
            z.insert(z.begin() + at, sp[2]);
            std::vector<double> got(x.size());
            detail::kernel_field(*k, x.data(), y.data(), z.data(), x.size(), got.data(), root);
            for (int i = 0; i <= kOrdinary; ++i) {
              const double want = i == at ? special_alone[0] : alone[i - (i > at)];
              ASSERT_EQ(got[i], want)
                  << (root ? "root" : "F") << " at " << i << ", special at " << at;
            }
          }
        }
      }
      hwy::SetSupportedTargetsForTest(0);
    }
  }
}

TEST(Kernel, BatchesOfAnySizeGiveThePointwiseValues) {
  // Lane refill must not mix up points (nor lose or hang on a lane): every batch size and offset
  // gives the same values, for the sweeps (rosa-rational) and the register loops (newton-cubic,
  // classic-julia).
  for (const char* name : {"rosa-rational", "newton-cubic", "classic-julia"}) {
    SCOPED_TRACE(name);
    const Params p = preset(name);
    const Classifier cls(p);
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-2, 2);
    const int n = 1000;
    std::vector<double> x(n), y(n), z(n);
    for (int i = 0; i < n; ++i) x[i] = u(rng), y[i] = u(rng), z[i] = u(rng);
    std::vector<float> all(n);
    cls.field(x.data(), y.data(), z.data(), n, all.data());
    for (int size : {1, 3, 5, 8, 13, 31, 32, 33, 200}) {
      std::vector<float> part(n);
      for (int i = 0; i < n; i += size)
        cls.field(x.data() + i, y.data() + i, z.data() + i, std::min(size, n - i), part.data() + i);
      for (int i = 0; i < n; ++i) ASSERT_EQ(part[i], all[i]) << "batch size " << size << ", " << i;
    }
  }
}

}  // namespace
}  // namespace qjulia
