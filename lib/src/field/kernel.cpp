// The vector kernel of kernel.h, compiled once per Highway target (AVX-512 and AVX2) and
// dispatched at run time.
//
// Up to M orbits are in flight, one per lane, stored as structure-of-arrays. A sweep advances
// every orbit by one step: each operation of the program runs over all M lanes in a tight loop
// (the dispatch is paid once per operation, not per vector), then one pass computes the metric
// of the new iterates and marks the lanes whose orbit has decided. Those lanes are retired into
// a buffer of finished orbits and refilled at once with the next waiting points (an expanding
// load on AVX-512), so the vectors stay full. F is computed for the finished orbits in bulk.
// Three kinds of program run instead in loops that keep a few vectors of orbits in registers
// (Machine::run_in_registers): one square plus an addition (h^2 + c, SquareStep), Newton's map
// of a cubic (CubicOverSquareStep) and chains of operations on literals (ChainStep), each lane
// computing exactly what the sweeps compute.
#include "field/kernel.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include "field/quat_functions.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "field/kernel.cpp"
// AVX2 is the baseline of the vector path, AVX-512 where the CPU has it; without AVX2 the
// scalar classifier runs. The 128-bit targets would only add compile time.
#ifndef HWY_DISABLED_TARGETS
#define HWY_DISABLED_TARGETS (HWY_SSSE3 | HWY_SSE4 | HWY_AVX3_DL)
#endif
// clang-format off
#include "hwy/foreach_target.h"  // IWYU pragma: keep
#include "hwy/highway.h"
#include "hwy/contrib/math/math-inl.h"
// clang-format on

#ifndef QJULIA_FIELD_KERNEL_ONCE
#define QJULIA_FIELD_KERNEL_ONCE
namespace qjulia::detail {
// F is clamped to +-kFieldLimit (as in the scalar classifier), so poles stay finite.
constexpr double kFieldLimit = 1e6;
// Most orbits in flight; fewer for programs with many registers, so the lanes stay in L1.
constexpr std::size_t kMaxInFlight = 256;
// Finished orbits buffered before their F is computed.
constexpr std::size_t kFinished = 1024;
// Sweeps between retirements of decided orbits.
constexpr std::uint64_t kRetireEvery = 2;
// Storage slots: one per register of the program.
constexpr int kSlots = kRegisters;

// The AVX2 path's lane tables, by a 4-bit lane mask m: the 32-bit lane indices of
// _mm256_permutevar8x32_ps that move the first popcount(m) doubles to the lanes of m, in order
// (an expanding load), and those that move the lanes of m to the front, in order (a compressing
// store; Highway's own table is a local array that GCC copies to the stack at every call); the
// lanes of m as a vector mask; and the first n lanes (n = 0..4).
struct Lanes4Tables {
  alignas(32) std::int32_t expand[16][8];
  alignas(32) std::int32_t compress[16][8];
  alignas(32) std::int64_t lanes[16][4];
  alignas(32) std::int64_t first[5][4];
};
constexpr Lanes4Tables make_lanes4_tables() {
  Lanes4Tables t{};
  for (int m = 0; m < 16; ++m) {
    int rank = 0;
    for (int j = 0; j < 4; ++j) {
      const bool in = (m >> j) & 1;
      t.expand[m][2 * j] = 2 * (in ? rank : 0);
      t.expand[m][2 * j + 1] = 2 * (in ? rank : 0) + 1;
      t.lanes[m][j] = in ? -1 : 0;
      if (in) {
        t.compress[m][2 * rank] = 2 * j;
        t.compress[m][2 * rank + 1] = 2 * j + 1;
      }
      rank += in ? 1 : 0;
    }
  }
  for (int n = 0; n <= 4; ++n)
    for (int j = 0; j < 4; ++j) t.first[n][j] = j < n ? -1 : 0;
  return t;
}
// (Not const: GCC copies a constant table to the stack before indexing it at run time.)
alignas(32) static Lanes4Tables kLanes4 = make_lanes4_tables();

// The AVX-512 logarithm's tables (log_normal()): for each sixteenth [1 + i/16, 1 + (i+1)/16)
// of the mantissas, the reciprocal of its centre rounded to a double, and minus the logarithm
// of that rounded reciprocal (computed in long double).
struct LogTables {
  alignas(64) double inv[16];
  alignas(64) double minus_log_inv[16];
};
inline LogTables make_log_tables() {
  LogTables t{};
  for (int i = 0; i < 16; ++i) {
    t.inv[i] = 1.0 / (1.0 + (i + 0.5) / 16.0);
    t.minus_log_inv[i] = static_cast<double>(-std::log(static_cast<long double>(t.inv[i])));
  }
  return t;
}
static const LogTables kLog = make_log_tables();
}  // namespace qjulia::detail
#endif

HWY_BEFORE_NAMESPACE();
namespace qjulia::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using D = hn::ScalableTag<double>;
using V = hn::Vec<D>;
using M = hn::Mask<D>;

struct Q {
  V w, x, y, z;
};

HWY_INLINE Q broadcast(const Quat& q) {
  const D d;
  return {hn::Set(d, q.w), hn::Set(d, q.x), hn::Set(d, q.y), hn::Set(d, q.z)};
}
HWY_INLINE V norm2(const Q& a) {
  return hn::MulAdd(a.z, a.z, hn::MulAdd(a.y, a.y, hn::MulAdd(a.x, a.x, hn::Mul(a.w, a.w))));
}
HWY_INLINE Q add(const Q& a, const Q& b) {
  return {hn::Add(a.w, b.w), hn::Add(a.x, b.x), hn::Add(a.y, b.y), hn::Add(a.z, b.z)};
}
HWY_INLINE Q sub(const Q& a, const Q& b) {
  return {hn::Sub(a.w, b.w), hn::Sub(a.x, b.x), hn::Sub(a.y, b.y), hn::Sub(a.z, b.z)};
}
HWY_INLINE Q scale(V s, const Q& a) {
  return {hn::Mul(s, a.w), hn::Mul(s, a.x), hn::Mul(s, a.y), hn::Mul(s, a.z)};
}
// Hamilton product.
HWY_INLINE Q mul(const Q& a, const Q& b) {
  return {
      hn::NegMulAdd(a.z, b.z, hn::NegMulAdd(a.y, b.y, hn::NegMulAdd(a.x, b.x, hn::Mul(a.w, b.w)))),
      hn::NegMulAdd(a.z, b.y, hn::MulAdd(a.y, b.z, hn::MulAdd(a.x, b.w, hn::Mul(a.w, b.x)))),
      hn::MulAdd(a.z, b.x, hn::MulAdd(a.y, b.w, hn::NegMulAdd(a.x, b.z, hn::Mul(a.w, b.y)))),
      hn::MulAdd(a.z, b.w, hn::NegMulAdd(a.y, b.x, hn::MulAdd(a.x, b.y, hn::Mul(a.w, b.z))))};
}
HWY_INLINE Q sqr(const Q& a) {
  const V t = hn::Add(a.w, a.w);
  return {
      hn::NegMulAdd(a.z, a.z, hn::NegMulAdd(a.y, a.y, hn::NegMulAdd(a.x, a.x, hn::Mul(a.w, a.w)))),
      hn::Mul(t, a.x), hn::Mul(t, a.y), hn::Mul(t, a.z)};
}
HWY_INLINE V reciprocal(V x);

// The point of slice coordinates (x, y, z): origin + x d0 + y d1 + z d2.
HWY_INLINE Q slice_point(V x, V y, V z, const Q& o, const Q& d0, const Q& d1, const Q& d2) {
  auto comp = [&](V ow, V a, V b, V c) {
    return hn::MulAdd(z, c, hn::MulAdd(y, b, hn::MulAdd(x, a, ow)));
  };
  return {comp(o.w, d0.w, d1.w, d2.w), comp(o.x, d0.x, d1.x, d2.x), comp(o.y, d0.y, d1.y, d2.y),
          comp(o.z, d0.z, d1.z, d2.z)};
}

// The point of slice coordinates (x, y, z) for s: by one addition a component where the slice
// is axis-aligned (KernelSetup::axis_slice) and the coordinates are finite (their sum is: an
// infinity or NaN makes it infinite or NaN), else by slice_point(); the same bits either way.
// slice_point() adds to the origin's component, in turn, the coordinate on that axis and the
// others times +0 (zeros with the others' signs): the sum is the coordinate plus the origin's
// component, except that a sum of zeros is -0 only when every term is; so an origin component
// of -0 (a negative fixed value times 0) stands for -0 when all three coordinates have their
// sign bit set, else +0. (The slice's sixteen constants broadcast and twelve fused
// multiply-adds were about a tenth of the register loop's time on classic-julia's box.)
HWY_INLINE Q point_of(const KernelSetup& s, V x, V y, V z) {
  const D d;
  if (s.axis_slice && HWY_LIKELY(hn::AllTrue(d, hn::IsFinite(hn::Add(hn::Add(x, y), z))))) {
    const V zero_of_signs =
        s.origin_negative_zero ? hn::And(hn::And(x, y), hn::And(z, hn::Set(d, -0.0))) : hn::Zero(d);
    auto comp = [&](int c) {
      const V base = (s.origin_negative_zero >> c) & 1 ? zero_of_signs : hn::Set(d, s.origin[c]);
      const int a = s.axis_of[c];
      return a < 0 ? base : hn::Add(a == 0 ? x : a == 1 ? y : z, base);
    };
    return {comp(0), comp(1), comp(2), comp(3)};
  }
  return slice_point(x, y, z, broadcast(s.origin), broadcast(s.dir[0]), broadcast(s.dir[1]),
                     broadcast(s.dir[2]));
}

// The lanes whose step metric makes their orbit leave: escape, |q|^2 > R^2 (NaN and inf leave
// too); cut-off, |q - h|^2 < r^2 (converged), or a pole or an overflow (a large step that never
// converges).
template <bool kEscape>
HWY_INLINE M leaves(V metric, V r2) {
  if (kEscape) return hn::Not(hn::Le(metric, r2));
  return hn::Or(hn::Not(hn::Ge(metric, r2)), hn::Not(hn::IsFinite(metric)));
}

// The metric of the step from h to q, |q|^2 (escape) or |q - h|^2 (cut-off), and whether the
// orbit leaves there (leaves()).
template <bool kEscape>
HWY_INLINE V step_metric(const Q& q, const Q& h, V r2, M& exit) {
  const V metric = kEscape ? norm2(q) : norm2(sub(q, h));
  exit = leaves<kEscape>(metric, r2);
  return metric;
}

// The step code a decided orbit keeps: its exit step k, -1 when it never left, -2 for a
// cut-off orbit that left on a non-finite step.
template <bool kEscape>
HWY_INLINE V exit_code(M exit, V k, V metric) {
  const D d;
  const V code = hn::IfThenElse(exit, k, hn::Set(d, -1.0));
  if (kEscape) return code;
  return hn::IfThenElse(hn::IsFinite(metric), code, hn::Set(d, -2.0));
}

// Calls f(std::integral_constant<std::size_t, I>()) for each I: loops over register groups
// with compile-time indices, so the groups' arrays can live in registers.
template <std::size_t... I, class F>
HWY_INLINE void each_group(std::index_sequence<I...>, F&& f) {
  (f(std::integral_constant<std::size_t, I>()), ...);
}
// each_group() over the groups 0 .. N-1.
template <std::size_t N, class F>
HWY_INLINE void for_groups(F&& f) {
  each_group(std::make_index_sequence<N>{}, f);
}

// One step of a single-operation map: h^2, plus the literal (kAdd 1), c (2) or the literal's
// real part (3); the metric and exit as step_metric().
template <int kAdd, bool kEscape>
HWY_INLINE Q single_op_step(const Q& h, const Q& c, const Q& lit, V r2, V& metric, M& exit) {
  // h^2 with the addition folded into its multiply-adds (as the reference kernel does).
  const Q& k = kAdd == 2 ? c : lit;
  const V t = hn::Add(h.w, h.w);
  const V ww = kAdd == 0 ? hn::Mul(h.w, h.w) : hn::MulAdd(h.w, h.w, k.w);
  Q q;
  q.w = hn::NegMulAdd(h.z, h.z, hn::NegMulAdd(h.y, h.y, hn::NegMulAdd(h.x, h.x, ww)));
  if (kAdd == 1 || kAdd == 2) {
    q.x = hn::MulAdd(t, h.x, k.x);
    q.y = hn::MulAdd(t, h.y, k.y);
    q.z = hn::MulAdd(t, h.z, k.z);
  } else {
    q.x = hn::Mul(t, h.x);
    q.y = hn::Mul(t, h.y);
    q.z = hn::Mul(t, h.z);
  }
  metric = step_metric<kEscape>(q, h, r2, exit);
  return q;
}

#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
// single_op_step() whose new iterate is 0 in the lanes outside `run` (the orbits that have
// decided compute on from 0 until they are refilled: no overflow or subnormal values on the
// way), the masking folded into the last operation of each component.
template <int kAdd, bool kEscape>
HWY_INLINE Q single_op_step_masked(__mmask8 run, const Q& h, const Q& c, const Q& lit, V r2,
                                   V& metric, M& exit) {
  const Q& k = kAdd == 2 ? c : lit;
  const __m512d t = _mm512_add_pd(h.w.raw, h.w.raw);
  __m512d w =
      kAdd == 0 ? _mm512_mul_pd(h.w.raw, h.w.raw) : _mm512_fmadd_pd(h.w.raw, h.w.raw, k.w.raw);
  w = _mm512_fnmadd_pd(h.x.raw, h.x.raw, w);
  w = _mm512_fnmadd_pd(h.y.raw, h.y.raw, w);
  Q q;
  q.w = V{_mm512_maskz_fnmadd_pd(run, h.z.raw, h.z.raw, w)};
  if (kAdd == 1 || kAdd == 2) {
    q.x = V{_mm512_maskz_fmadd_pd(run, t, h.x.raw, k.x.raw)};
    q.y = V{_mm512_maskz_fmadd_pd(run, t, h.y.raw, k.y.raw)};
    q.z = V{_mm512_maskz_fmadd_pd(run, t, h.z.raw, k.z.raw)};
  } else {
    q.x = V{_mm512_maskz_mul_pd(run, t, h.x.raw)};
    q.y = V{_mm512_maskz_mul_pd(run, t, h.y.raw)};
    q.z = V{_mm512_maskz_mul_pd(run, t, h.z.raw)};
  }
  metric = step_metric<kEscape>(q, h, r2, exit);
  return q;
}
#endif

// The lanes of m that are not positive normal numbers: NaN, +-0, +-inf, subnormal or negative
// (one vfpclasspd on AVX-512).
HWY_INLINE M not_positive_normal(V m) {
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  return M{_mm512_fpclass_pd_mask(m.raw, 0xFF)};
#else
  const D d;
  return hn::Not(hn::And(hn::Ge(m, hn::Set(d, std::numeric_limits<double>::min())),
                         hn::Le(m, hn::Set(d, std::numeric_limits<double>::max()))));
#endif
}

// 1 / n for a squared norm n: the fast reciprocal where n is a normal number, a division
// elsewhere (0, subnormal, inf), so poles and overflow come out as in the scalar path.
HWY_INLINE V reciprocal_of_norm(V n) {
  const D d;
  const V r = reciprocal(n);
  const M special = not_positive_normal(n);
  if (HWY_LIKELY(hn::AllFalse(d, special))) return r;
  return hn::IfThenElse(special, hn::Div(hn::Set(d, 1.0), n), r);
}

// conj(a) / |a|^2; a zero quaternion gives non-finite components, as in the scalar path.
HWY_INLINE Q inv(const Q& a) {
  const Q n = scale(reciprocal_of_norm(norm2(a)), a);
  return {n.w, hn::Neg(n.x), hn::Neg(n.y), hn::Neg(n.z)};
}

// mul(t, inv(b)) with inv(b)'s negations taken into the product's signs (a product with a
// negated factor is the negated product, exactly): the same values.
HWY_INLINE Q mul_by_inverse(const Q& t, const Q& b) {
  const Q n = scale(reciprocal_of_norm(norm2(b)), b);  // inv(b) = (iw, -nx, -ny, -nz)
  const V iw = n.w, nx = n.x, ny = n.y, nz = n.z;
  // mul()'s operations term by term: fma(p, -n, c) = fnma(p, n, c), fma(p, q, -c) = fms(p, q,
  // c), and fma(-p, n, -c) = -fma(p, n, c) under rounding to nearest.
  return {hn::MulAdd(t.z, nz, hn::MulAdd(t.y, ny, hn::MulAdd(t.x, nx, hn::Mul(t.w, iw)))),
          hn::MulAdd(t.z, ny, hn::NegMulAdd(t.y, nz, hn::MulSub(t.x, iw, hn::Mul(t.w, nx)))),
          hn::NegMulAdd(t.z, nx, hn::MulAdd(t.y, iw, hn::MulSub(t.x, nz, hn::Mul(t.w, ny)))),
          hn::MulAdd(t.z, iw, hn::MulSub(t.y, nx, hn::MulAdd(t.x, ny, hn::Mul(t.w, nz))))};
}

#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL || HWY_TARGET == HWY_AVX2
// The maps whose orbits the register loops (Machine::run_in_registers, on AVX-512 and AVX2) run:
// step(run, h, c, r2, metric, exit) gives the next iterate, which is `idle` in the lanes outside
// `run` (decided or empty); the loop keeps kGroup vectors of orbits in flight, and c of each lane
// where kUsesC.
#if HWY_TARGET == HWY_AVX2
using RunMask = __m256d;  // every bit of a lane set
constexpr bool kWide = false;
// q in the lanes of `run`, idle elsewhere.
HWY_INLINE Q keep(RunMask run, const Q& q, const Q& idle) {
  return {
      V{_mm256_blendv_pd(idle.w.raw, q.w.raw, run)}, V{_mm256_blendv_pd(idle.x.raw, q.x.raw, run)},
      V{_mm256_blendv_pd(idle.y.raw, q.y.raw, run)}, V{_mm256_blendv_pd(idle.z.raw, q.z.raw, run)}};
}
#else
using RunMask = __mmask8;
constexpr bool kWide = true;
HWY_INLINE Q keep(RunMask run, const Q& q, const Q& idle) {
  return {V{_mm512_mask_mov_pd(idle.w.raw, run, q.w.raw)},
          V{_mm512_mask_mov_pd(idle.x.raw, run, q.x.raw)},
          V{_mm512_mask_mov_pd(idle.y.raw, run, q.y.raw)},
          V{_mm512_mask_mov_pd(idle.z.raw, run, q.z.raw)}};
}
#endif

// h^2 plus the literal (kAdd 1), c (2), the literal's real part (3) or nothing (0); idle lanes
// compute on from 0.
template <int kAdd>
struct SquareStep {
  static constexpr bool kUsesC = kAdd == 2;
  // c of each lane needs registers too; AVX2 has 16 of them.
  static constexpr std::size_t kGroup = kAdd == 2 ? 2 : kWide ? 4 : 3;
  Q lit;
  explicit SquareStep(const KernelSetup& s) : lit(broadcast(s.kops[0].add_lit)) {}
  static HWY_INLINE Q idle() {
    const V zero = hn::Zero(D());
    return {zero, zero, zero, zero};
  }
  template <bool kEscape>
  HWY_INLINE Q step(RunMask run, const Q& h, const Q& c, V r2, V& metric, M& exit) const {
#if HWY_TARGET == HWY_AVX2
    const Q q = single_op_step<kAdd, kEscape>(h, c, lit, r2, metric, exit);
    return {V{_mm256_and_pd(q.w.raw, run)}, V{_mm256_and_pd(q.x.raw, run)},
            V{_mm256_and_pd(q.y.raw, run)}, V{_mm256_and_pd(q.z.raw, run)}};
#else
    return single_op_step_masked<kAdd, kEscape>(run, h, c, lit, r2, metric, exit);
#endif
  }
};

// (s1 (s0 h^2) h + a) / (s2 h^2) with real s0, s1, s2 and a: Newton's map of a cubic, as the
// formula compiler writes (2*h^3+1)/(3*h^2). The same operations as the program's, in its
// order, so every lane computes what the sweeps do; with kUnitS0 (s0 = 1, as in that formula)
// the product by s0 is left out, and the inverse's negated components are negated in the
// product that takes them: both exact, so the values are the same.
template <bool kUnitS0>
struct CubicOverSquareStep {
  static constexpr bool kUsesC = false;
  static constexpr std::size_t kGroup = kWide ? 3 : 2;
  V s0, s1, a, s2;
  explicit CubicOverSquareStep(const KernelSetup& s)
      : s0(hn::Set(D(), s.kops[0].scale)),
        s1(hn::Set(D(), s.kops[1].scale)),
        a(hn::Set(D(), s.kops[1].add_lit.w)),
        s2(hn::Set(D(), s.kops[2].scale)) {}
  // 1: finite and far from 0, so the inverse keeps its fast path in idle lanes.
  static HWY_INLINE Q idle() {
    const V zero = hn::Zero(D());
    return {hn::Set(D(), 1.0), zero, zero, zero};
  }
  template <bool kEscape>
  HWY_INLINE Q step(RunMask run, const Q& h, const Q&, V r2, V& metric, M& exit) const {
    const Q square = sqr(h);  // the program squares h twice, with the same result
    Q top = scale(s1, mul(kUnitS0 ? square : scale(s0, square), h));
    top.w = hn::Add(top.w, a);
    const Q q = mul_by_inverse(top, scale(s2, square));
    metric = step_metric<kEscape>(q, h, r2, exit);
    return keep(run, q, idle());
  }
};
#endif

// The analytic functions. q = a + t u (t = |vector part|, u its direction, u = i when t = 0)
// behaves as the complex number a + t i: f(q) = Re f(a + t i) + u Im f(a + t i). Lanes outside
// the ranges where Highway's functions hold (or non-finite) take the scalar reference.
struct Plane {
  V a, t, ux, uy, uz;
};

HWY_INLINE Plane split(const Q& q) {
  const D d;
  const V t2 = hn::MulAdd(q.z, q.z, hn::MulAdd(q.y, q.y, hn::Mul(q.x, q.x)));
  const V t = hn::Sqrt(t2);
  const auto pos = hn::Gt(t, hn::Zero(d));
  const V inv =
      hn::IfThenElseZero(pos, hn::Div(hn::Set(d, 1.0), hn::IfThenElse(pos, t, hn::Set(d, 1.0))));
  return {q.w, t, hn::IfThenElse(pos, hn::Mul(q.x, inv), hn::Set(d, 1.0)), hn::Mul(q.y, inv),
          hn::Mul(q.z, inv)};
}

HWY_INLINE Q join(const Plane& p, V re, V im) {
  return {re, hn::Mul(im, p.ux), hn::Mul(im, p.uy), hn::Mul(im, p.uz)};
}

// sinh and cosh of a real s with |s| <= 700, from one expm1 (no cancellation near 0).
HWY_INLINE void sinh_cosh(V s, V* sh, V* ch) {
  const D d;
  const V half = hn::Set(d, 0.5), one = hn::Set(d, 1.0);
  const V e = hn::Expm1(d, hn::Abs(s));
  const V ep1 = hn::Add(e, one);
  const V r = hn::Div(one, ep1);
  *sh = hn::CopySign(hn::Mul(half, hn::Add(e, hn::Mul(e, r))), s);
  *ch = hn::Mul(half, hn::Add(ep1, r));
}

// atan2(y, x) for y >= 0.
HWY_INLINE V atan2_upper(V y, V x) {
  const D d;
  const V ax = hn::Abs(x);
  const V big = hn::Max(ax, y), small = hn::Min(ax, y);
  const auto nonzero = hn::Gt(big, hn::Zero(d));
  const V r = hn::Atan(d, hn::Div(small, hn::IfThenElse(nonzero, big, hn::Set(d, 1.0))));
  const V half_pi = hn::Set(d, 1.5707963267948966192), pi = hn::Set(d, 3.1415926535897932385);
  V theta = hn::IfThenElse(hn::Gt(y, ax), hn::Sub(half_pi, r), r);
  theta = hn::IfThenElse(hn::Lt(x, hn::Zero(d)), hn::Sub(pi, theta), theta);
  return hn::IfThenElseZero(nonzero, theta);
}

HWY_INLINE Q analytic(OpCode code, const Q& q, double x) {
  const D d;
  const Plane p = split(q);
  const V zero = hn::Zero(d), one = hn::Set(d, 1.0), half = hn::Set(d, 0.5);
  auto within = [&](V v, double lim) { return hn::Le(hn::Abs(v), hn::Set(d, lim)); };
  // Lanes for the scalar path: non-finite input, extreme magnitudes, beyond the ranges, or a
  // vector part so small that its squared length leaves the normal numbers (the scalar path
  // rescales it and keeps its axis; here the axis would be lost).
  const auto tiny =
      hn::And(hn::Lt(p.t, hn::Set(d, 1.5e-154)),
              hn::Not(hn::And(hn::Eq(q.x, zero), hn::And(hn::Eq(q.y, zero), hn::Eq(q.z, zero)))));
  M ok = hn::And(hn::And(hn::IsFinite(p.a), hn::IsFinite(p.t)),
                 hn::AndNot(tiny, hn::And(within(p.a, 1e150), within(p.t, 1e150))));
  Q r;
  switch (code) {
    case OpCode::kExp: {
      ok = hn::And(ok, hn::And(hn::Le(p.a, hn::Set(d, 700.0)), within(p.t, 3.9e4)));
      const V e = hn::Exp(d, p.a);
      r = join(p, hn::Mul(e, hn::Cos(d, p.t)), hn::Mul(e, hn::Sin(d, p.t)));
      break;
    }
    case OpCode::kLog: {
      const V n2 = hn::MulAdd(p.t, p.t, hn::Mul(p.a, p.a));
      ok = hn::And(ok, hn::Gt(n2, hn::Set(d, 1e-300)));
      r = join(p, hn::Mul(half, hn::Log(d, hn::IfThenElse(ok, n2, one))), atan2_upper(p.t, p.a));
      break;
    }
    case OpCode::kSqrt: {
      const V m = hn::Sqrt(hn::MulAdd(p.t, p.t, hn::Mul(p.a, p.a)));
      ok = hn::And(ok, hn::Gt(m, hn::Set(d, 1e-300)));
      const auto pos = hn::Ge(p.a, zero);
      const V s = hn::Sqrt(hn::Mul(half, hn::IfThenElse(pos, hn::Add(m, p.a), hn::Sub(m, p.a))));
      const V other = hn::Div(p.t, hn::Add(s, s));
      r = join(p, hn::IfThenElse(pos, s, other), hn::IfThenElse(pos, other, s));
      break;
    }
    case OpCode::kSin:
    case OpCode::kCos: {
      ok = hn::And(ok, hn::And(within(p.a, 3.9e4), within(p.t, 700.0)));
      V sh, ch;
      sinh_cosh(p.t, &sh, &ch);
      const V sa = hn::Sin(d, p.a), ca = hn::Cos(d, p.a);
      r = code == OpCode::kSin ? join(p, hn::Mul(sa, ch), hn::Mul(ca, sh))
                               : join(p, hn::Mul(ca, ch), hn::Neg(hn::Mul(sa, sh)));
      break;
    }
    case OpCode::kTan: {
      // (sin a cos a + i sinh t cosh t) / (cos^2 a + sinh^2 t): no cancellation near the poles.
      ok = hn::And(ok, hn::And(within(p.a, 3.9e4), within(p.t, 350.0)));
      V sh, ch;
      sinh_cosh(p.t, &sh, &ch);
      const V sa = hn::Sin(d, p.a), ca = hn::Cos(d, p.a);
      const V den = hn::MulAdd(sh, sh, hn::Mul(ca, ca));
      const V inv = hn::Div(one, den);
      r = join(p, hn::Mul(hn::Mul(sa, ca), inv), hn::Mul(hn::Mul(sh, ch), inv));
      break;
    }
    case OpCode::kSinh:
    case OpCode::kCosh: {
      ok = hn::And(ok, hn::And(within(p.a, 700.0), within(p.t, 3.9e4)));
      V sh, ch;
      sinh_cosh(p.a, &sh, &ch);
      const V st = hn::Sin(d, p.t), ct = hn::Cos(d, p.t);
      r = code == OpCode::kSinh ? join(p, hn::Mul(sh, ct), hn::Mul(ch, st))
                                : join(p, hn::Mul(ch, ct), hn::Mul(sh, st));
      break;
    }
    case OpCode::kTanh: {
      // (sinh a cosh a + i sin t cos t) / (sinh^2 a + cos^2 t).
      ok = hn::And(ok, hn::And(within(p.a, 350.0), within(p.t, 3.9e4)));
      V sh, ch;
      sinh_cosh(p.a, &sh, &ch);
      const V st = hn::Sin(d, p.t), ct = hn::Cos(d, p.t);
      const V inv = hn::Div(one, hn::MulAdd(ct, ct, hn::Mul(sh, sh)));
      r = join(p, hn::Mul(hn::Mul(sh, ch), inv), hn::Mul(hn::Mul(st, ct), inv));
      break;
    }
    default: {  // kPowReal: exp(x log q)
      const V n2 = hn::MulAdd(p.t, p.t, hn::Mul(p.a, p.a));
      ok = hn::And(ok, hn::Gt(n2, hn::Set(d, 1e-300)));
      const V xv = hn::Set(d, x);
      const V lr = hn::Mul(xv, hn::Mul(half, hn::Log(d, hn::IfThenElse(ok, n2, one))));
      const V li = hn::Mul(xv, atan2_upper(p.t, p.a));
      ok = hn::And(ok, hn::And(hn::Le(lr, hn::Set(d, 700.0)), within(li, 3.9e4)));
      const V e = hn::Exp(d, hn::IfThenElse(ok, lr, zero));
      r = join(p, hn::Mul(e, hn::Cos(d, li)), hn::Mul(e, hn::Sin(d, li)));
      break;
    }
  }
  if (HWY_UNLIKELY(!hn::AllTrue(d, ok))) {
    HWY_ALIGN double w[8], xs[8], ys[8], zs[8];
    hn::Store(r.w, d, w);
    hn::Store(r.x, d, xs);
    hn::Store(r.y, d, ys);
    hn::Store(r.z, d, zs);
    HWY_ALIGN double in[4][8];
    hn::Store(q.w, d, in[0]);
    hn::Store(q.x, d, in[1]);
    hn::Store(q.y, d, in[2]);
    hn::Store(q.z, d, in[3]);
    std::uint8_t bits[8] = {};
    hn::StoreMaskBits(d, hn::Not(ok), bits);
    for (std::size_t i = 0; i < hn::Lanes(d); ++i) {
      if (!(bits[i / 8] & (1u << (i % 8)))) continue;
      const Quat a(in[0][i], in[1][i], in[2][i], in[3][i]);
      Quat v;
      switch (code) {
        case OpCode::kExp:
          v = qexp(a);
          break;
        case OpCode::kLog:
          v = qlog(a);
          break;
        case OpCode::kSqrt:
          v = qsqrt(a);
          break;
        case OpCode::kSin:
          v = qsin(a);
          break;
        case OpCode::kCos:
          v = qcos(a);
          break;
        case OpCode::kTan:
          v = qtan(a);
          break;
        case OpCode::kSinh:
          v = qsinh(a);
          break;
        case OpCode::kCosh:
          v = qcosh(a);
          break;
        case OpCode::kTanh:
          v = qtanh(a);
          break;
        default:
          v = qpow(a, x);
          break;
      }
      w[i] = v.w;
      xs[i] = v.x;
      ys[i] = v.y;
      zs[i] = v.z;
    }
    r = {hn::Load(d, w), hn::Load(d, xs), hn::Load(d, ys), hn::Load(d, zs)};
  }
  return r;
}

// The lanes of a register: four component arrays.
struct Slot {
  double* c[4];
  HWY_INLINE Q load(std::size_t o) const {
    const D d;
    return {hn::Load(d, c[0] + o), hn::Load(d, c[1] + o), hn::Load(d, c[2] + o),
            hn::Load(d, c[3] + o)};
  }
  HWY_INLINE void store(std::size_t o, const Q& q) const {
    const D d;
    hn::Store(q.w, d, c[0] + o);
    hn::Store(q.x, d, c[1] + o);
    hn::Store(q.y, d, c[2] + o);
    hn::Store(q.z, d, c[3] + o);
  }
};

// Writes the lanes of v selected by m to p consecutively and returns how many; the lanes after
// them are overwritten with garbage (the caller writes there later). The register form of the
// AVX-512 compress: its memory form is slow on Intel cores.
HWY_INLINE std::size_t compress_store(V v, M m, double* p) {
  const D d;
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  hn::StoreU(V{_mm512_maskz_compress_pd(m.raw, v.raw)}, d, p);
#elif HWY_TARGET == HWY_AVX2
  const unsigned bits = static_cast<unsigned>(_mm256_movemask_pd(m.raw));
  const __m256i perm = _mm256_load_si256(reinterpret_cast<const __m256i*>(kLanes4.compress[bits]));
  _mm256_storeu_pd(p, _mm256_castps_pd(_mm256_permutevar8x32_ps(_mm256_castpd_ps(v.raw), perm)));
  return static_cast<std::size_t>(__builtin_popcount(bits));
#else
  hn::StoreU(hn::Compress(v, m), d, p);
#endif
  return hn::CountTrue(d, m);
}

// 1 / x within an ulp or so: the estimate and two Newton steps, for the last operations of F
// (its logarithms and its fraction), whose rounding no later step amplifies; the orbits' own
// inverses take reciprocal(), whose third step rounds as the scalar path's division does.
HWY_INLINE V reciprocal_final(V x) {
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  const V one = hn::Set(D(), 1.0);
  V r{_mm512_rcp14_pd(x.raw)};
  r = hn::MulAdd(r, hn::NegMulAdd(x, r, one), r);
  return hn::MulAdd(r, hn::NegMulAdd(x, r, one), r);
#else
  return hn::Div(hn::Set(D(), 1.0), x);
#endif
}

// 1 / x to full double precision without a division: the 14-bit reciprocal estimate and
// three Newton steps (vdivpd is slow; the orbits' inverses need one a step).
HWY_INLINE V reciprocal(V x) {
  const D d;
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  // The third step makes it correctly rounded nearly always; infinities and zeros pass through
  // the estimate unchanged in the cases F meets (1/inf = 0 is masked by the callers).
  const V r = reciprocal_final(x);
  return hn::MulAdd(r, hn::NegMulAdd(x, r, hn::Set(d, 1.0)), r);
#else
  return hn::Div(hn::Set(d, 1.0), x);
#endif
}

// a / (a + b) for a > 0, b >= 0, either possibly infinite (the fractional part of F); without
// kSpecial, for finite a and b.
template <bool kSpecial>
HWY_INLINE V frac(V a, V b) {
  const D d;
  V r = hn::Mul(a, reciprocal_final(hn::Add(a, b)));
  if (!kSpecial) return r;
  const auto ia = hn::IsInf(a), ib = hn::IsInf(b);
  r = hn::IfThenElse(ib, hn::Zero(d), r);
  return hn::IfThenElse(ia, hn::IfThenElse(ib, hn::Set(d, 0.5), hn::Set(d, 1.0)), r);
}

// The natural logarithm of m > 0 (finite, not subnormal). AVX-512: x = 2^e m with m in [1, 2)
// (vgetexp, vgetmant); m's sixteenth i (its fraction's top four bits) gives the rounded
// reciprocal v of its centre and -log v from two 16-entry tables (two permutes), and
// log m = -log v + log1p(r) with r = m v - 1, |r| < 1/32, from its series to r^10 (the next
// term is below 3e-18). Elsewhere: musl's method as in Highway's Log, with the one division
// replaced by a reciprocal.
HWY_INLINE V log_normal(V x) {
  const D d;
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  const __m512d m = _mm512_getmant_pd(x.raw, _MM_MANT_NORM_1_2, _MM_MANT_SIGN_src);
  const V e{_mm512_getexp_pd(x.raw)};
  const __m512i i = _mm512_srli_epi64(_mm512_castpd_si512(m), 48);  // the low 4 bits count
  const V v{_mm512_permutex2var_pd(_mm512_load_pd(kLog.inv), i, _mm512_load_pd(kLog.inv + 8))};
  const V minus_log_v{_mm512_permutex2var_pd(_mm512_load_pd(kLog.minus_log_inv), i,
                                             _mm512_load_pd(kLog.minus_log_inv + 8))};
  const V r = hn::MulSub(V{m}, v, hn::Set(d, 1.0));
  const V r2 = hn::Mul(r, r), r4 = hn::Mul(r2, r2);
  // log1p(r) = r + r^2 S, S = -1/2 + r/3 - r^2/4 + ... - r^8/10, by pairs of terms.
  const V a0 = hn::MulAdd(r, hn::Set(d, 1.0 / 3), hn::Set(d, -1.0 / 2));
  const V a1 = hn::MulAdd(r, hn::Set(d, 1.0 / 5), hn::Set(d, -1.0 / 4));
  const V a2 = hn::MulAdd(r, hn::Set(d, 1.0 / 7), hn::Set(d, -1.0 / 6));
  const V a3 = hn::MulAdd(r, hn::Set(d, 1.0 / 9), hn::Set(d, -1.0 / 8));
  const V b0 = hn::MulAdd(r2, a1, a0);
  const V b1 = hn::MulAdd(r4, hn::Set(d, -1.0 / 10), hn::MulAdd(r2, a3, a2));
  const V log1p = hn::MulAdd(r2, hn::MulAdd(r4, b1, b0), r);
  // e log 2 in two parts (the first exact for any exponent), added last to the small terms.
  return hn::Add(hn::MulAdd(e, hn::Set(d, 0.693147180369123816490), minus_log_v),
                 hn::MulAdd(e, hn::Set(d, 1.90821492927058770002e-10), log1p));
#else
  const hn::RebindToSigned<D> di;
  const hn::RebindToUnsigned<D> du;
  const V one = hn::Set(d, 1.0);
  const auto exp_bits =
      hn::Add(hn::BitCast(di, x), hn::Set(di, 0x3FF0000000000000LL - 0x3FE6A09E00000000LL));
  const V e = hn::ConvertTo(
      d,
      hn::Sub(hn::BitCast(di, hn::ShiftRight<52>(hn::BitCast(du, exp_bits))), hn::Set(di, 0x3FF)));
  const V y = hn::Or(hn::And(x, hn::BitCast(d, hn::Set(di, 0xFFFFFFFFLL))),
                     hn::BitCast(d, hn::Add(hn::And(exp_bits, hn::Set(di, 0xFFFFF00000000LL)),
                                            hn::Set(di, 0x3FE6A09E00000000LL))));
  const V ym1 = hn::Sub(y, one);
  const V z = hn::Mul(ym1, reciprocal_final(hn::Add(y, one)));
  const V z2 = hn::Mul(z, z), z4 = hn::Mul(z2, z2);
  const V poly = hn::MulAdd(hn::MulAdd(hn::MulAdd(hn::MulAdd(hn::Set(d, 0.1479819860511658591), z4,
                                                             hn::Set(d, 0.1818357216161805012)),
                                                  z4, hn::Set(d, 0.2857142874366239149)),
                                       z4, hn::Set(d, 0.6666666666666735130)),
                            z2,
                            hn::Mul(hn::MulAdd(hn::MulAdd(hn::Set(d, 0.1531383769920937332), z4,
                                                          hn::Set(d, 0.2222219843214978396)),
                                               z4, hn::Set(d, 0.3999999999940941908)),
                                    z4));
  return hn::MulSub(
      e, hn::Set(d, 0.693147180369123816490),
      hn::Sub(hn::MulSub(z, hn::Sub(ym1, poly), hn::Mul(e, hn::Set(d, 1.90821492927058770002e-10))),
              ym1));
#endif
}

// log(sqrt(m) / R) = 0.5 log m - log R; +inf for non-finite m, -inf for m = 0. Without
// kSpecial, for positive normal m.
template <bool kSpecial>
HWY_INLINE V half_log_ratio(V m, double log_r) {
  const D d;
  const V half = hn::Set(d, 0.5), lr = hn::Set(d, log_r);
  if (!kSpecial) return hn::Sub(hn::Mul(half, log_normal(m)), lr);
  const V inf = hn::Set(d, std::numeric_limits<double>::infinity());
  const auto finite = hn::IsFinite(m);
  const auto positive = hn::Gt(m, hn::Zero(d));
  const auto normal = hn::Ge(m, hn::Set(d, std::numeric_limits<double>::min()));
  const V safe = hn::IfThenElse(hn::And(finite, normal), m, hn::Set(d, 1.0));
  V l = log_normal(safe);
  if (HWY_UNLIKELY(!hn::AllTrue(d, hn::Or(normal, hn::Not(positive)))))
    l = hn::IfThenElse(normal, l, hn::Log(d, hn::IfThenElse(positive, m, hn::Set(d, 1.0))));
  l = hn::Sub(hn::Mul(half, l), lr);
  return hn::IfThenElse(finite, hn::IfThenElse(positive, l, hn::Neg(inf)), inf);
}

// f within +-limit, NaN taken as +limit.
HWY_INLINE V clamp_field(V f) {
  const D d;
  const V big = hn::Set(d, kFieldLimit), nbig = hn::Set(d, -kFieldLimit);
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  // vminpd gives its second operand when either is NaN: the clamp takes NaN to +limit itself.
  return V{_mm512_max_pd(_mm512_min_pd(f.raw, big.raw), nbig.raw)};
#else
  return hn::IfThenElse(hn::IsNaN(f), big, hn::Min(big, hn::Max(nbig, f)));
#endif
}

// What F and the refinement value read of the setup, held by value: a loop that scatters its
// results through a pointer would otherwise load them again at every vector (the stores may
// alias the setup).
struct FieldConsts {
  bool escape;
  int iterations;
  double log_r;
  explicit FieldConsts(const KernelSetup& s)
      : escape(s.escape), iterations(s.iterations), log_r(s.log_r) {}
};

// F of decided orbits from their code (exit / convergence step, -1 never, -2 pole), metric a
// and previous metric b: the formulas of the scalar classifier, lane by lane. Without kSpecial,
// for a vector whose metrics are all positive normal numbers, where none of the special cases'
// tests can apply (the same operations on the same values otherwise).
template <bool kSpecial>
HWY_INLINE V field_formula(const FieldConsts& s, V k, V a, V b) {
  const D d;
  const V nbig = hn::Set(d, -kFieldLimit);
  const V iters = hn::Set(d, s.iterations), one = hn::Set(d, 1.0);
  const V sa = half_log_ratio<kSpecial>(a, s.log_r), sb = half_log_ratio<kSpecial>(b, s.log_r);
  V f;
  if (s.escape) {
    // step 0: N + frac(s, 1); step n: (N - n) + frac(s_n, -s_(n-1)) with s_(n-1) taken as -1
    // when h_(n-1) = 0; never: s_N.
    // (One frac for both: N - 0 is N exactly.)
    const V sprev = kSpecial ? hn::IfThenElse(hn::Gt(b, hn::Zero(d)), sb, hn::Set(d, -1.0)) : sb;
    const V other = hn::IfThenElse(hn::Eq(k, hn::Zero(d)), one, hn::Neg(sprev));
    f = hn::Add(hn::Sub(iters, k), frac<kSpecial>(sa, other));
    f = hn::IfThenElse(hn::Lt(k, hn::Zero(d)), sa, f);
  } else {
    // step 1: (N - 1) + frac(-t, 1); step n: (N - n) + frac(-t_n, t_(n-1)); never: -t_N;
    // pole: -limit.
    // (One frac for both: N - k is N - 1 at step 1.)
    const V nt = hn::Neg(sa);
    f = hn::Add(hn::Sub(iters, k), frac<kSpecial>(nt, hn::IfThenElse(hn::Eq(k, one), one, sb)));
    f = hn::IfThenElse(hn::Eq(k, hn::Set(d, -1.0)), nt, f);
    f = hn::IfThenElse(hn::Eq(k, hn::Set(d, -2.0)), nbig, f);
  }
  // (Without kSpecial a sum of 0 in the fraction still gives NaN, clamped here.)
  return clamp_field(f);
}

// The value refinement finds the boundary with: max_k s_k (escape) or -min_k t_k (cut-off) over
// the orbit up to its decision: exactly the method's test (the point is in the solid when it is
// <= 0), and continuous everywhere, unlike F, whose formula changes at the boundary. A pole
// (cut-off) gives -limit.
// Decided at step k, it is read from the metric then (the first beyond the bailout, or below
// the cut-off, so also the extreme so far); never decided, from the extreme over the orbit.
HWY_INLINE V root_metric(V k, V a, V b) {
  return hn::IfThenElse(hn::Eq(k, hn::Set(D(), -1.0)), b, a);
}

template <bool kSpecial>
HWY_INLINE V root_formula(const FieldConsts& s, V k, V a, V b) {
  const D d;
  const V big = hn::Set(d, kFieldLimit);
  const V sa = half_log_ratio<kSpecial>(root_metric(k, a, b), s.log_r);
  V g = s.escape ? sa : hn::Neg(sa);
  if (!s.escape) g = hn::IfThenElse(hn::Eq(k, hn::Set(d, -2.0)), hn::Neg(big), g);
  return clamp_field(g);
}

// The lanes of a vector of decided orbits that need the special cases of F (kRoot false) or of
// the refinement value (kRoot true): a metric it reads that is not a positive normal number.
template <bool kRoot>
HWY_INLINE M needs_special(V k, V a, V b) {
  if (kRoot) return not_positive_normal(root_metric(k, a, b));
  return hn::Or(not_positive_normal(a), not_positive_normal(b));
}

template <bool kRoot, bool kSpecial>
HWY_INLINE V value_formula(const FieldConsts& s, V k, V a, V b) {
  return kRoot ? root_formula<kSpecial>(s, k, a, b) : field_formula<kSpecial>(s, k, a, b);
}

// F or the refinement value of two vectors of decided orbits, the short way where it can.
// Both at once, in one block without a branch when neither needs the special cases: each is a
// long chain of dependent operations (two logarithms, a reciprocal), and two independent
// chains side by side keep the vector units busy where one after the other left them waiting.
template <bool kRoot>
HWY_INLINE void values_of_two(const FieldConsts& s, const V (&k)[2], const V (&a)[2],
                              const V (&b)[2], V (&f)[2]) {
  const D d;
  const M s0 = needs_special<kRoot>(k[0], a[0], b[0]);
  const M s1 = needs_special<kRoot>(k[1], a[1], b[1]);
  if (HWY_LIKELY(hn::AllFalse(d, hn::Or(s0, s1)))) {
    f[0] = value_formula<kRoot, false>(s, k[0], a[0], b[0]);
    f[1] = value_formula<kRoot, false>(s, k[1], a[1], b[1]);
    return;
  }
  auto one = [&](int i, M special) {
    return hn::AllFalse(d, special) ? value_formula<kRoot, false>(s, k[i], a[i], b[i])
                                    : value_formula<kRoot, true>(s, k[i], a[i], b[i]);
  };
  f[0] = one(0, s0);
  f[1] = one(1, s1);
}

#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL || HWY_TARGET == HWY_AVX2
// A chain of up to kLinks operations, the first on h, each next on the one before, with
// literal operands only: a square, an analytic function, a negation, conjugate or inverse, a
// product with, sum with or real factor of a literal, and the fused real factor and addition of
// a literal (pq-quadratic's p h^2 + q, sine-julia's 1.8 sin(h), power-screw's h^1.5 + c). Each
// operation computes what Machine::apply computes for it, so every lane gets what the sweeps
// give.
struct ChainStep {
  static constexpr int kLinks = 3;
  static constexpr bool kUsesC = false;
  static constexpr std::size_t kGroup = 2;
  KernelOp ops[kLinks];
  int links = 0;
  explicit ChainStep(const KernelSetup& s) : links(static_cast<int>(s.kops.size())) {
    for (int i = 0; i < links; ++i) ops[i] = s.kops[i];
  }
  // Whether the operation can be a link (its operand aside).
  static bool link(const KernelOp& op) {
    switch (op.code) {
      case OpCode::kNeg:
      case OpCode::kConj:
      case OpCode::kInv:
      case OpCode::kSqr:
      case OpCode::kAddReal:
      case OpCode::kAddLit:
      case OpCode::kScale:
      case OpCode::kMulLit:
      case OpCode::kLitMul:
      case OpCode::kScaleAddReal:
        return op.add != 2;
      default:
        return op.code >= OpCode::kExp && op.add == 0 && op.scale == 1;
    }
  }
  // 1: finite, and inside every analytic function's vector range.
  static HWY_INLINE Q idle() {
    const V zero = hn::Zero(D());
    return {hn::Set(D(), 1.0), zero, zero, zero};
  }
  // The fused real factor and addition of a product (Machine::with_add).
  static HWY_INLINE Q with_add(const KernelOp& op, Q q) {
    if (op.scale != 1) q = scale(hn::Set(D(), op.scale), q);
    if (op.add == 1) q = add(q, broadcast(op.add_lit));
    if (op.add == 3) q.w = hn::Add(q.w, hn::Set(D(), op.add_lit.w));
    return q;
  }
  static HWY_INLINE Q apply(const KernelOp& op, const Q& a) {
    const D d;
    switch (op.code) {
      case OpCode::kNeg:
        return {hn::Neg(a.w), hn::Neg(a.x), hn::Neg(a.y), hn::Neg(a.z)};
      case OpCode::kConj:
        return {a.w, hn::Neg(a.x), hn::Neg(a.y), hn::Neg(a.z)};
      case OpCode::kInv:
        return inv(a);
      case OpCode::kSqr:
        return with_add(op, sqr(a));
      case OpCode::kAddReal: {
        Q q = a;
        q.w = hn::Add(q.w, hn::Set(d, op.lit.w));
        return q;
      }
      case OpCode::kAddLit:
        return add(a, broadcast(op.lit));
      case OpCode::kScale:
        return with_add(op, scale(hn::Set(d, op.lit.w), a));
      case OpCode::kMulLit:
        return with_add(op, mul(a, broadcast(op.lit)));
      case OpCode::kLitMul:
        return with_add(op, mul(broadcast(op.lit), a));
      case OpCode::kScaleAddReal: {
        Q q = scale(hn::Set(d, op.lit.w), a);
        q.w = hn::Add(q.w, hn::Set(d, op.lit.x));
        return q;
      }
      default:
        return analytic(op.code, a, op.lit.w);
    }
  }
  template <bool kEscape>
  HWY_INLINE Q step(RunMask run, const Q& h, const Q&, V r2, V& metric, M& exit) const {
    Q q = apply(ops[0], h);
    for (int i = 1; i < links; ++i) q = apply(ops[i], q);
    metric = step_metric<kEscape>(q, h, r2, exit);
    return keep(run, q, idle());
  }
};
#endif

class Machine {
 public:
  // F (or the refinement value) into out, or rounded to float into out_float (one of them).
  std::uint64_t run(const KernelSetup& s, const double* x, const double* y, const double* z,
                    std::size_t n, double* out, float* out_float, bool root) {
    root_ = root;
    s_ = &s;
    out_ = out;
    out_float_ = out_float;
    steps_ = 0;
    fcount_ = 0;
    const std::size_t nl = hn::Lanes(D());
    // Lanes in flight: fewer for programs with many registers, never more than the points.
    lanes_ = s.registers <= 5    ? kMaxInFlight
             : s.registers <= 10 ? kMaxInFlight / 2
                                 : kMaxInFlight / 4;
    lanes_ = std::min(lanes_, (n + nl - 1) / nl * nl);
    setup_slots();
    switch (loop()) {
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL || HWY_TARGET == HWY_AVX2
      case KernelLoop::kSquare:
        run_square(x, y, z, n);
        break;
      case KernelLoop::kCubicOverSquare:
        if (s_->kops[0].scale == 1)
          run_step<CubicOverSquareStep<true>>(x, y, z, n);
        else
          run_step<CubicOverSquareStep<false>>(x, y, z, n);
        break;
      case KernelLoop::kChain:
        run_step<ChainStep>(x, y, z, n);
        break;
#endif
      default:
        queue(x, y, z, n);
        start();
        while (live_ > 0) sweep();
    }
    flush();
    return steps_;
  }

  // The loop run() takes for s's program on this target.
  KernelLoop loop(const KernelSetup& s) {
    s_ = &s;
    return loop();
  }

 private:
  // Storage for the registers: h in slot 0 and a spare (they swap after every step when the
  // result is a temporary), c in its register's slot, uniform constants broadcast once.
  void setup_slots() {
    const std::size_t stride = kMaxInFlight + 8;
    if (storage_.empty()) storage_.resize(static_cast<std::size_t>(kSlots) * 4 * stride + 8);
    double* base = storage_.data();
    base += (64 - reinterpret_cast<std::uintptr_t>(base) % 64) % 64 / sizeof(double);
    for (int r = 0; r < kSlots; ++r)
      for (int c = 0; c < 4; ++c)
        slot_[r].c[c] = base + (static_cast<std::size_t>(r) * 4 + c) * stride;
    for (int r = 1; r < s_->registers; ++r)
      if (s_->uniform[r])
        for (int c = 0; c < 4; ++c) std::fill_n(slot_[r].c[c], lanes_, s_->init[r][c]);
    result_is_temp_ = s_->result != 0 && s_->result != s_->c_register && !s_->uniform[s_->result];
  }

  // The points into the queue: h0 (and c in Mandelbrot mode) by the slice; an escape orbit
  // that starts outside the ball has decided at step 0.
  void queue(const double* x, const double* y, const double* z, std::size_t n) {
    const D d;
    const std::size_t nl = hn::Lanes(d);
    const bool with_c = s_->c_register >= 0;
    for (int c = 0; c < 4; ++c) {
      qh_[c].resize(n + nl);
      if (with_c) qc_[c].resize(n + nl);
    }
    qidx_.resize(n + nl);
    qprev_.resize(n + nl);
    queued_ = taken_ = 0;
    const Q start = broadcast(s_->start);
    HWY_ALIGN double lane_index[8] = {0, 1, 2, 3, 4, 5, 6, 7};
    const V iota = hn::Load(d, lane_index);
    const V inf = hn::Set(d, std::numeric_limits<double>::infinity());
    for (std::size_t i = 0; i < n; i += nl) {
      const std::size_t m = std::min(nl, n - i);
      V vx, vy, vz;
      if (m == nl) {
        vx = hn::LoadU(d, x + i);
        vy = hn::LoadU(d, y + i);
        vz = hn::LoadU(d, z + i);
      } else {
        HWY_ALIGN double bx[8] = {}, by[8] = {}, bz[8] = {};
        std::copy_n(x + i, m, bx);
        std::copy_n(y + i, m, by);
        std::copy_n(z + i, m, bz);
        vx = hn::Load(d, bx);
        vy = hn::Load(d, by);
        vz = hn::Load(d, bz);
      }
      const Q q = point_of(*s_, vx, vy, vz);
      const Q h = s_->mandelbrot ? start : q;
      const V idx = hn::Add(iota, hn::Set(d, static_cast<double>(i)));
      M valid = hn::FirstN(d, m);
      V prev = inf;  // cut-off: no step before the first
      if (s_->escape) {
        prev = norm2(h);
        const M outside = hn::And(valid, hn::Gt(prev, hn::Set(d, s_->r2)));
        if (!hn::AllFalse(d, outside)) {
          finished(outside, hn::Zero(d), prev, prev, idx);
          valid = hn::AndNot(outside, valid);
        }
      }
      const std::size_t at = queued_;
      auto put = [&](V v, std::vector<double>& to) {
        if (m == nl && hn::AllTrue(d, valid))
          hn::StoreU(v, d, to.data() + at);
        else
          compress_store(v, valid, to.data() + at);
      };
      put(h.w, qh_[0]);
      put(h.x, qh_[1]);
      put(h.y, qh_[2]);
      put(h.z, qh_[3]);
      if (with_c) {
        put(q.w, qc_[0]);
        put(q.x, qc_[1]);
        put(q.y, qc_[2]);
        put(q.z, qc_[3]);
      }
      put(prev, qprev_);
      put(idx, qidx_);
      queued_ += hn::CountTrue(d, valid);
    }
  }

  // Fills the lanes from the queue; lanes beyond it are idle.
  void start() {
    const std::size_t take = std::min(lanes_, queued_);
    for (int c = 0; c < 4; ++c) {
      std::copy_n(qh_[c].data(), take, slot_[0].c[c]);
      std::fill(slot_[0].c[c] + take, slot_[0].c[c] + lanes_, 0.0);
      if (s_->c_register >= 0) {
        std::copy_n(qc_[c].data(), take, slot_[s_->c_register].c[c]);
        std::fill(slot_[s_->c_register].c[c] + take, slot_[s_->c_register].c[c] + lanes_, 0.0);
      }
    }
    std::copy_n(qprev_.data(), take, prev_);
    std::copy_n(qprev_.data(), take, ext_);
    std::copy_n(qidx_.data(), take, idx_);
    std::fill(start_, start_ + lanes_, 0.0);
    std::fill(pending_, pending_ + lanes_, 0.0);
    std::fill(frozen_, frozen_ + lanes_, 0.0);
    for (std::size_t i = take; i < lanes_; ++i) set_bits(frozen_[i]);
    taken_ = take;
    live_ = take;
    sweeps_ = 0;
  }

  static void set_bits(double& v) { std::memset(&v, 0xff, sizeof v); }

  // The running extreme of the metric over the orbit (the largest |h_k|^2 for escape, the
  // smallest step for cut-off): the refinement value of an orbit that never decides.
  HWY_INLINE V extreme(V ext, V metric) const {
    return s_->escape ? hn::Max(ext, metric) : hn::Min(ext, metric);
  }
  // What a decided orbit keeps as its second value: the previous metric (for F), or the
  // extreme for an orbit that never decided (F does not use the previous metric there). A loop
  // that keeps no extreme (kExt false: it computes F only) keeps the previous metric.
  template <bool kExt = true>
  static HWY_INLINE V second(V code, V prev, V ext) {
    if (!kExt) return prev;
    return hn::IfThenElse(hn::Eq(code, hn::Set(D(), -1.0)), ext, prev);
  }

  // One step of every orbit in flight; every few sweeps, retirement and refill.
  void sweep() {
    ++sweeps_;
    for (const KernelOp& op : s_->kops) apply(op);
    const Slot next = slot_[s_->result];
    check(next);
    // The new iterates become h: by swapping storage when the result is a temporary (the next
    // sweep writes it before reading it), else they were copied into h by check().
    if (result_is_temp_) std::swap(slot_[0], slot_[s_->result]);
    std::swap(prev_, metric_);
    // Decided lanes wait (frozen, computing on) until the next retirement: retiring in bulk
    // every kRetireEvery sweeps costs less than the steps the waiting lanes lose.
    if (sweeps_ % kRetireEvery == 0 || queued_ == taken_) retire_all();
  }

  // The metric of every new iterate; lanes whose orbit decided keep what F needs (step code,
  // metric, previous metric) and freeze until they are retired.
  void check(const Slot& next) {
    const D d;
    const std::size_t nl = hn::Lanes(d);
    const Slot& h = slot_[0];
    const V r2 = hn::Set(d, s_->r2), iters = hn::Set(d, s_->iterations);
    const V g = hn::Set(d, static_cast<double>(sweeps_));
    for (std::size_t o = 0; o < lanes_; o += nl) {
      const Q q = next.load(o);
      M exit;
      const V metric = s_->escape ? step_metric<true>(q, q, r2, exit)
                                  : step_metric<false>(q, h.load(o), r2, exit);
      if (!result_is_temp_ && s_->result != 0) h.store(o, q);
      hn::Store(metric, d, metric_ + o);
      const V ext = extreme(hn::Load(d, ext_ + o), metric);
      hn::Store(ext, d, ext_ + o);
      const V k = hn::Sub(g, hn::Load(d, start_ + o));
      const M open = hn::Not(hn::MaskFromVec(hn::Load(d, frozen_ + o)));
      const M now = hn::And(open, hn::Or(exit, hn::Eq(k, iters)));
      if (hn::AllFalse(d, now)) continue;
      const V code =
          s_->escape ? exit_code<true>(exit, k, metric) : exit_code<false>(exit, k, metric);
      hn::BlendedStore(code, now, d, cap_code_ + o);
      hn::BlendedStore(metric, now, d, cap_a_ + o);
      hn::BlendedStore(second(code, hn::Load(d, prev_ + o), ext), now, d, cap_b_ + o);
      const V all = hn::VecFromMask(d, now);
      hn::Store(hn::Or(all, hn::Load(d, frozen_ + o)), d, frozen_ + o);
      hn::Store(hn::Or(all, hn::Load(d, pending_ + o)), d, pending_ + o);
      any_pending_ = true;
    }
  }

  // The register loops run on AVX-512 and AVX2 only; elsewhere every program takes the sweeps.
  KernelLoop loop() const {
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL || HWY_TARGET == HWY_AVX2
    if (single_op()) return KernelLoop::kSquare;
    if (cubic_over_square()) return KernelLoop::kCubicOverSquare;
    if (chain()) return KernelLoop::kChain;
#endif
    return KernelLoop::kSweeps;
  }

#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL || HWY_TARGET == HWY_AVX2
  // A program that is one square of h plus an addition (h^2 + c in Julia and Mandelbrot
  // mode, h^2), run by run_square. A real factor fused into the square (2*h^2 - 0.8) is not:
  // SquareStep applies none. Such a map runs as a chain, or through the sweeps where it adds c
  // per lane (Mandelbrot mode).
  bool single_op() const {
    if (s_->kops.size() != 1) return false;
    const KernelOp& op = s_->kops[0];
    return op.code == OpCode::kSqr && op.a == 0 && op.dst == s_->result && op.scale == 1 &&
           (op.add != 2 || (op.add_reg == s_->c_register && s_->c_register > 0));
  }

  // A program of CubicOverSquareStep's form: h2 = s0 h^2; t = s1 (h2 h) + a (a real); u = s2
  // h^2; f = t inv(u).
  bool cubic_over_square() const {
    const std::vector<KernelOp>& k = s_->kops;
    if (k.size() != 4) return false;
    const KernelOp &h2 = k[0], &t = k[1], &u = k[2], &f = k[3];
    return h2.code == OpCode::kSqr && h2.a == 0 && h2.add == 0 && h2.dst != 0 &&
           t.code == OpCode::kMul && t.a == h2.dst && t.b == 0 && t.add == 3 && t.dst != 0 &&
           t.dst != h2.dst && u.code == OpCode::kSqr && u.a == 0 && u.add == 0 && u.dst != 0 &&
           u.dst != t.dst && f.code == OpCode::kDiv && f.a == t.dst && f.b == u.dst &&
           f.dst == s_->result;
  }

  // A program of ChainStep's form: each operation a link, the first reading h, each next the
  // register the one before wrote, h never overwritten, the last writing the result.
  bool chain() const {
    const std::vector<KernelOp>& k = s_->kops;
    if (k.empty() || k.size() > static_cast<std::size_t>(ChainStep::kLinks)) return false;
    for (std::size_t i = 0; i < k.size(); ++i)
      if (!ChainStep::link(k[i]) || k[i].a != (i == 0 ? 0 : k[i - 1].dst) || k[i].dst == 0)
        return false;
    return k.back().dst == s_->result;
  }

  // The square loop for the addition the program fuses into its square: none, a literal, c
  // (per lane in Mandelbrot mode) or a real.
  void run_square(const double* x, const double* y, const double* z, std::size_t n) {
    switch (s_->kops[0].add) {
      case 0:
        return run_step<SquareStep<0>>(x, y, z, n);
      case 1:
        return run_step<SquareStep<1>>(x, y, z, n);
      case 2:
        return run_step<SquareStep<2>>(x, y, z, n);
      default:
        return run_step<SquareStep<3>>(x, y, z, n);
    }
  }

  // The register loop of Step for this setup's method, keeping each orbit's extreme where the
  // refinement values are asked for (root_of; F, field_of, reads the last metric and the one
  // before).
  template <class Step>
  void run_step(const double* x, const double* y, const double* z, std::size_t n) {
    if (s_->escape) {
      if (root_)
        run_in_registers<Step, true, true>(x, y, z, n);
      else
        run_in_registers<Step, true, false>(x, y, z, n);
    } else {
      if (root_)
        run_in_registers<Step, false, true>(x, y, z, n);
      else
        run_in_registers<Step, false, false>(x, y, z, n);
    }
  }
#endif

#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  // AVX-512: every orbit's state stays in registers for the whole batch. The steps run without
  // a branch on the data: a lane that decides freezes (its step count, metrics and extreme
  // take masked updates) and idles; every kSteps steps, a vector in which kRefillAt lanes wait
  // sends its decided orbits to the finished buffer (compressing stores) and takes the next
  // waiting points (expanding loads). A data-dependent branch at every step cost more than the
  // idle lanes. Every group index is a compile-time constant (each_group), so the groups' state
  // lives in registers: state kept in stack arrays was stored at every step, and those stores
  // aliased (4 KiB apart) the loads of the points at some stack offsets, which made the speed
  // of a process depend on the size of its environment.
  // The loop of every map with a step of its own (SquareStep, CubicOverSquareStep, ChainStep).
  template <class Step, bool kEscape, bool kExt>
  HWY_NOINLINE void run_in_registers(const double* x, const double* y, const double* z,
                                     std::size_t n) {
    const Step st(*s_);
    constexpr std::size_t kGroup = Step::kGroup;
    // Steps between refills, and the waiting lanes that make a vector refill: 2 and 2 ran the
    // band of `qjulia bench --kernel` 1.01-1.42x as fast as 4 and 3 on an AMD EPYC (16 pairs).
    constexpr int kSteps = 2;
    constexpr int kRefillAt = 2;
    const D d;
    const V r2 = hn::Set(d, s_->r2), iters = hn::Set(d, s_->iterations), one = hn::Set(d, 1.0);
    const V zero = hn::Zero(d), inf = hn::Set(d, std::numeric_limits<double>::infinity());
    // Per group: h (and c), the steps taken k, the last metric a and the one before, the
    // extreme; masks of the lanes still running and of those holding an orbit (running or
    // decided since their last refill). The steps update only the running lanes' mask: which
    // decided orbits left is read from their last metric when they are finished (mask
    // operations share ports with the vector arithmetic on some CPUs, and eight mask registers
    // do not hold three masks of four groups).
    Q h[kGroup], c[kGroup];
    V k[kGroup], a[kGroup], prev[kGroup], ext[kGroup];
    __mmask8 live[kGroup], held[kGroup];
    // The points straight from the slice, without the queue, as queue() computes them; each
    // lane's point index waits in idx_ (read only when the lane's orbit is finished). The
    // slice's constants are read at each refill, not held in registers the steps need.
    HWY_ALIGN static constexpr double kIota[8] = {0, 1, 2, 3, 4, 5, 6, 7};
    std::size_t next = 0;  // the next point of the slice
    // Loads the next points into the lanes of `want` (as many as are left); an escape orbit that
    // starts outside the ball has decided at step 0 and goes straight to the finished ones, its
    // lane taking the point after. Returns the lanes filled.
    auto load = [&](auto group, __mmask8 want) __attribute__((always_inline))->__mmask8 {
      constexpr std::size_t g = decltype(group)::value;
      __mmask8 filled = 0;
      while (want != 0 && next < n) {
        __mmask8 m = want;
        if (static_cast<std::size_t>(__builtin_popcount(want)) > n - next)
          m = static_cast<__mmask8>(_pdep_u32((1u << (n - next)) - 1, want));
        // Contiguous masked loads, then expansion in registers (expanding loads from memory
        // are slow on some CPUs).
        const unsigned count = static_cast<unsigned>(__builtin_popcount(m));
        const __mmask8 first = static_cast<__mmask8>((1u << count) - 1);
        const V vx{_mm512_maskz_expand_pd(m, _mm512_maskz_loadu_pd(first, x + next))};
        const V vy{_mm512_maskz_expand_pd(m, _mm512_maskz_loadu_pd(first, y + next))};
        const V vz{_mm512_maskz_expand_pd(m, _mm512_maskz_loadu_pd(first, z + next))};
        const V id{
            _mm512_maskz_expand_pd(m, hn::Add(hn::Load(d, kIota), hn::Set(d, double(next))).raw)};
        next += count;
        const Q q = point_of(*s_, vx, vy, vz);
        const Q h0 = s_->mandelbrot ? broadcast(s_->start) : q;
        __mmask8 ok = m;
        V p = hn::Set(d, std::numeric_limits<double>::infinity());  // cut-off: no step before
        if (kEscape) {
          p = norm2(h0);
          const __mmask8 out = m & hn::Gt(p, r2).raw;
          if (out != 0) {
            finished(M{out}, zero, p, p, id);
            ok &= static_cast<__mmask8>(~out);
          }
        }
        h[g] = {V{_mm512_mask_mov_pd(h[g].w.raw, ok, h0.w.raw)},
                V{_mm512_mask_mov_pd(h[g].x.raw, ok, h0.x.raw)},
                V{_mm512_mask_mov_pd(h[g].y.raw, ok, h0.y.raw)},
                V{_mm512_mask_mov_pd(h[g].z.raw, ok, h0.z.raw)}};
        if (Step::kUsesC)
          c[g] = {V{_mm512_mask_mov_pd(c[g].w.raw, ok, q.w.raw)},
                  V{_mm512_mask_mov_pd(c[g].x.raw, ok, q.x.raw)},
                  V{_mm512_mask_mov_pd(c[g].y.raw, ok, q.y.raw)},
                  V{_mm512_mask_mov_pd(c[g].z.raw, ok, q.z.raw)}};
        a[g] = V{_mm512_mask_mov_pd(a[g].raw, ok, p.raw)};
        if (kExt) ext[g] = V{_mm512_mask_mov_pd(ext[g].raw, ok, p.raw)};
        k[g] = V{_mm512_mask_mov_pd(k[g].raw, ok, zero.raw)};
        _mm512_mask_store_pd(idx_ + 8 * g, ok, id.raw);
        filled |= ok;
        want &= static_cast<__mmask8>(~ok);
      }
      return filled;
    };
    for_groups<kGroup>([&](auto group) __attribute__((always_inline)) {
      constexpr std::size_t g = decltype(group)::value;
      h[g] = Step::idle();
      c[g] = {zero, zero, zero, zero};
      k[g] = a[g] = prev[g] = ext[g] = zero;
      live[g] = held[g] = load(group, 0xff);
    });
    for (;;) {
      // kSteps steps of every vector, without a branch on the data.
      for (int step = 0; step < kSteps; ++step) {
        for_groups<kGroup>([&](auto group) __attribute__((always_inline)) {
          constexpr std::size_t g = decltype(group)::value;
          V metric;
          M exit;  // not read: the masked compares below decide
          const __mmask8 run = live[g];
          // Lanes outside `run` (decided, or empty) compute on from the step's idle value.
          const Q q = st.template step<kEscape>(run, h[g], c[g], r2, metric, exit);
          k[g] = V{_mm512_mask_add_pd(k[g].raw, run, k[g].raw, one.raw)};
          if (kExt)
            ext[g] = V{kEscape ? _mm512_mask_max_pd(ext[g].raw, run, ext[g].raw, metric.raw)
                               : _mm512_mask_min_pd(ext[g].raw, run, ext[g].raw, metric.raw)};
          prev[g] = V{_mm512_mask_mov_pd(prev[g].raw, run, a[g].raw)};
          a[g] = V{_mm512_mask_mov_pd(a[g].raw, run, metric.raw)};
          // Running on: within the bailout (escape) or not converged and finite (cut-off),
          // and short of N steps; as compares masked by the lanes before, the negation of
          // leaves().
          __mmask8 on;
          if (kEscape) {
            on = _mm512_mask_cmp_pd_mask(run, metric.raw, r2.raw, _CMP_LE_OQ);
          } else {
            on = _mm512_mask_cmp_pd_mask(run, metric.raw, r2.raw, _CMP_GE_OQ);
            on = _mm512_mask_cmp_pd_mask(on, metric.raw, inf.raw, _CMP_LT_OQ);
          }
          live[g] = _mm512_mask_cmp_pd_mask(on, k[g].raw, iters.raw, _CMP_NEQ_OQ);
          h[g] = q;  // a lane decided now is zeroed at the next step
        });
      }
      // Decided lanes to the finished orbits; refilled once enough of a vector waits.
      bool any = false;
      for_groups<kGroup>([&](auto group) __attribute__((always_inline)) {
        constexpr std::size_t g = decltype(group)::value;
        const __mmask8 waiting = static_cast<__mmask8>(~live[g]);
        const __mmask8 pending = held[g] & waiting;  // decided since the last refill
        if (pending && (__builtin_popcount(waiting) >= kRefillAt || live[g] == 0)) {
          const V code = exit_code<kEscape>(leaves<kEscape>(a[g], r2), k[g], a[g]);
          finished(M{pending}, code, a[g], second<kExt>(code, prev[g], ext[g]),
                   hn::Load(d, idx_ + 8 * g));
          live[g] |= load(group, waiting);
          held[g] = live[g];
        }
        any = any || live[g] != 0;
      });
      if (!any) break;
    }
    live_ = 0;
  }
#elif HWY_TARGET == HWY_AVX2
  // AVX2: the AVX-512 path above with the masks as vectors (every bit of a lane set) and the
  // expanding loads done by lane tables (a masked load of the next points, then a permutation):
  // the state of kGroup vectors stays in registers, the steps run without a branch on the data,
  // a decided lane freezes (masked updates, its iterate the step's idle value) until its vector
  // refills.
  template <class Step, bool kEscape, bool kExt>
  HWY_NOINLINE void run_in_registers(const double* x, const double* y, const double* z,
                                     std::size_t n) {
    const Step st(*s_);
    constexpr std::size_t kGroup = Step::kGroup;
    constexpr int kSteps = 4;                          // steps between refills
    constexpr int kRefillAt = 2;                       // waiting lanes that make a vector refill
    const D d;
    const V r2 = hn::Set(d, s_->r2), iters = hn::Set(d, s_->iterations), one = hn::Set(d, 1.0);
    const V zero = hn::Zero(d);
    Q h[kGroup], c[kGroup];
    V k[kGroup], a[kGroup], prev[kGroup], ext[kGroup];
    __m256d live[kGroup], held[kGroup];  // as in the AVX-512 path
    HWY_ALIGN static constexpr double kIota[4] = {0, 1, 2, 3};
    std::size_t next = 0;  // the next point of the slice
    auto lanes_of = [](unsigned m) __attribute__((always_inline)) {
      return _mm256_load_pd(reinterpret_cast<const double*>(kLanes4.lanes[m]));
    };
    // Loads the next points into the lanes of `want`, as the AVX-512 path's load().
    auto load = [&](auto group, unsigned want) __attribute__((always_inline))->__m256d {
      constexpr std::size_t g = decltype(group)::value;
      __m256d filled = _mm256_setzero_pd();
      while (want != 0 && next < n) {
        unsigned m = want;
        while (static_cast<std::size_t>(__builtin_popcount(m)) > n - next)
          m &= ~(1u << (31 - __builtin_clz(m)));  // keep the lowest lanes
        const unsigned count = static_cast<unsigned>(__builtin_popcount(m));
        const __m256i first =
            _mm256_load_si256(reinterpret_cast<const __m256i*>(kLanes4.first[count]));
        const __m256i perm = _mm256_load_si256(reinterpret_cast<const __m256i*>(kLanes4.expand[m]));
        auto expand = [&](__m256d v) __attribute__((always_inline)) {
          return V{_mm256_castps_pd(_mm256_permutevar8x32_ps(_mm256_castpd_ps(v), perm))};
        };
        const V vx = expand(_mm256_maskload_pd(x + next, first));
        const V vy = expand(_mm256_maskload_pd(y + next, first));
        const V vz = expand(_mm256_maskload_pd(z + next, first));
        const V id = expand(hn::Add(hn::Load(d, kIota), hn::Set(d, double(next))).raw);
        next += count;
        const Q q = point_of(*s_, vx, vy, vz);
        const Q h0 = s_->mandelbrot ? broadcast(s_->start) : q;
        __m256d ok = lanes_of(m);
        unsigned okbits = m;
        V p = hn::Set(d, std::numeric_limits<double>::infinity());  // cut-off: no step before
        if (kEscape) {
          p = norm2(h0);
          const __m256d out = _mm256_and_pd(ok, _mm256_cmp_pd(p.raw, r2.raw, _CMP_GT_OQ));
          const unsigned outbits = static_cast<unsigned>(_mm256_movemask_pd(out));
          if (outbits != 0) {
            finished(M{out}, zero, p, p, id);
            ok = _mm256_andnot_pd(out, ok);
            okbits &= ~outbits;
          }
        }
        h[g] = {V{_mm256_blendv_pd(h[g].w.raw, h0.w.raw, ok)},
                V{_mm256_blendv_pd(h[g].x.raw, h0.x.raw, ok)},
                V{_mm256_blendv_pd(h[g].y.raw, h0.y.raw, ok)},
                V{_mm256_blendv_pd(h[g].z.raw, h0.z.raw, ok)}};
        if (Step::kUsesC)
          c[g] = {V{_mm256_blendv_pd(c[g].w.raw, q.w.raw, ok)},
                  V{_mm256_blendv_pd(c[g].x.raw, q.x.raw, ok)},
                  V{_mm256_blendv_pd(c[g].y.raw, q.y.raw, ok)},
                  V{_mm256_blendv_pd(c[g].z.raw, q.z.raw, ok)}};
        a[g] = V{_mm256_blendv_pd(a[g].raw, p.raw, ok)};
        if (kExt) ext[g] = V{_mm256_blendv_pd(ext[g].raw, p.raw, ok)};
        k[g] = V{_mm256_andnot_pd(ok, k[g].raw)};
        _mm256_maskstore_pd(idx_ + 4 * g, _mm256_castpd_si256(ok), id.raw);
        filled = _mm256_or_pd(filled, ok);
        want &= ~okbits;
      }
      return filled;
    };
    for_groups<kGroup>([&](auto group) __attribute__((always_inline)) {
      constexpr std::size_t g = decltype(group)::value;
      h[g] = Step::idle();
      c[g] = {zero, zero, zero, zero};
      k[g] = a[g] = prev[g] = ext[g] = zero;
      live[g] = held[g] = load(group, 0xf);
    });
    for (;;) {
      for (int step = 0; step < kSteps; ++step) {
        for_groups<kGroup>([&](auto group) __attribute__((always_inline)) {
          constexpr std::size_t g = decltype(group)::value;
          const __m256d run = live[g];
          V metric;
          M exit;
          // Lanes outside `run` (decided, or empty) compute on from the step's idle value; their
          // metric and exit are not used.
          const Q q = st.template step<kEscape>(run, h[g], c[g], r2, metric, exit);
          k[g] = hn::Add(k[g], V{_mm256_and_pd(one.raw, run)});
          if (kExt)
            ext[g] = V{_mm256_blendv_pd(
                ext[g].raw, (kEscape ? hn::Max(ext[g], metric) : hn::Min(ext[g], metric)).raw,
                run)};
          prev[g] = V{_mm256_blendv_pd(prev[g].raw, a[g].raw, run)};
          a[g] = V{_mm256_blendv_pd(a[g].raw, metric.raw, run)};
          // Running on: not leaving, and short of N steps.
          const __m256d on = _mm256_andnot_pd(exit.raw, run);
          live[g] = _mm256_andnot_pd(_mm256_cmp_pd(k[g].raw, iters.raw, _CMP_EQ_OQ), on);
          h[g] = q;
        });
      }
      // Decided lanes to the finished orbits; refilled once enough of a vector waits.
      bool any = false;
      for_groups<kGroup>([&](auto group) __attribute__((always_inline)) {
        constexpr std::size_t g = decltype(group)::value;
        const unsigned livebits = static_cast<unsigned>(_mm256_movemask_pd(live[g]));
        const unsigned waiting = ~livebits & 0xfu;
        const __m256d pending = _mm256_andnot_pd(live[g], held[g]);
        if (_mm256_movemask_pd(pending) != 0 &&
            (__builtin_popcount(waiting) >= kRefillAt || livebits == 0)) {
          const V code = exit_code<kEscape>(leaves<kEscape>(a[g], r2), k[g], a[g]);
          finished(M{pending}, code, a[g], second<kExt>(code, prev[g], ext[g]),
                   hn::Load(d, idx_ + 4 * g));
          live[g] = _mm256_or_pd(live[g], load(group, waiting));
          held[g] = live[g];
        }
        any = any || _mm256_movemask_pd(live[g]) != 0;
      });
      if (!any) break;
    }
    live_ = 0;
  }
#endif

  // Records every decided orbit and refills its lane from the queue (or idles it).
  void retire_all() {
    if (!any_pending_) return;
    any_pending_ = false;
    const D d;
    const std::size_t nl = hn::Lanes(d);
    for (std::size_t o = 0; o < lanes_; o += nl) {
      const M done = hn::MaskFromVec(hn::Load(d, pending_ + o));
      if (hn::AllFalse(d, done)) continue;
      finished(done, hn::Load(d, cap_code_ + o), hn::Load(d, cap_a_ + o), hn::Load(d, cap_b_ + o),
               hn::Load(d, idx_ + o));
      refill(o, done);
    }
  }

  // New points into the lanes of `done` at o (h, c, previous metric, point, start), which
  // thaw; lanes the queue cannot fill become idle.
  void refill(std::size_t o, M done) {
    const D d;
    const std::size_t nl = hn::Lanes(d);
    const Slot& h = slot_[0];
    hn::Store(hn::Zero(d), d, pending_ + o);
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
    const std::size_t want = hn::CountTrue(d, done);
    const V g = hn::Set(d, static_cast<double>(sweeps_));
    if (queued_ - taken_ >= want) {
      const __mmask8 m = done.raw;
      // A contiguous masked load expanded in registers (the memory form of the expanding load
      // is slow on some CPUs).
      const __mmask8 first = static_cast<__mmask8>((1u << want) - 1);
      auto expand = [&](const double* src, double* dst) {
        _mm512_store_pd(dst, _mm512_mask_expand_pd(_mm512_load_pd(dst), m,
                                                   _mm512_maskz_loadu_pd(first, src + taken_)));
      };
      for (int c = 0; c < 4; ++c) {
        expand(qh_[c].data(), h.c[c] + o);
        if (s_->c_register >= 0) expand(qc_[c].data(), slot_[s_->c_register].c[c] + o);
      }
      expand(qprev_.data(), prev_ + o);
      expand(qprev_.data(), ext_ + o);
      expand(qidx_.data(), idx_ + o);
      hn::Store(hn::IfThenElse(done, g, hn::Load(d, start_ + o)), d, start_ + o);
      hn::Store(hn::IfThenElseZero(hn::Not(done), hn::Load(d, frozen_ + o)), d, frozen_ + o);
      taken_ += want;
      return;
    }
#endif
    std::uint8_t bits[8] = {};
    hn::StoreMaskBits(d, done, bits);
    for (std::size_t i = 0; i < nl; ++i) {
      if (!(bits[i / 8] & (1u << (i % 8)))) continue;
      const std::size_t lane = o + i;
      if (taken_ < queued_) {
        for (int c = 0; c < 4; ++c) {
          h.c[c][lane] = qh_[c][taken_];
          if (s_->c_register >= 0) slot_[s_->c_register].c[c][lane] = qc_[c][taken_];
        }
        prev_[lane] = qprev_[taken_];
        ext_[lane] = qprev_[taken_];
        idx_[lane] = qidx_[taken_];
        start_[lane] = static_cast<double>(sweeps_);
        frozen_[lane] = 0.0;
        ++taken_;
      } else {
        for (int c = 0; c < 4; ++c) h.c[c][lane] = 0.0;  // idles on harmless values
        --live_;
      }
    }
  }

  // Appends decided orbits (code, metric, previous metric, point) to the finished buffer.
  void finished(M m, V code, V a, V b, V idx) {
    const D d;
    compress_store(code, m, fcode_ + fcount_);
    compress_store(a, m, fa_ + fcount_);
    compress_store(b, m, fb_ + fcount_);
    fcount_ += compress_store(idx, m, fidx_ + fcount_);
    if (fcount_ + hn::Lanes(d) > kFinished) flush();
  }

  // F of the finished orbits, written to their points.
  void flush() {
    const D d;
    const std::size_t nl = hn::Lanes(d);
    HWY_ALIGN double f[8] = {};
    // Pad to a whole pair of vectors with harmless orbits of no steps.
    for (std::size_t i = fcount_; i % (2 * nl); ++i) {
      fcode_[i] = 0;
      fa_[i] = fb_[i] = 1;
      fidx_[i] = -1;
    }
    // Everything the loop reads besides the buffers in locals: the scatter's stores could
    // alias the members and the setup, which would be loaded again at every vector.
    const FieldConsts fc(*s_);
    const std::size_t count = fcount_;
    double* const out = out_;
    float* const out_float = out_float_;
    const V iters = hn::Set(d, s_->iterations);
    V steps = hn::Zero(d);
    auto each = [&](auto root, auto single) __attribute__((always_inline)) {
      for (std::size_t i = 0; i < count; i += 2 * nl) {
        const V k[2] = {hn::Load(d, fcode_ + i), hn::Load(d, fcode_ + i + nl)};
        const V a[2] = {hn::Load(d, fa_ + i), hn::Load(d, fa_ + i + nl)};
        const V b[2] = {hn::Load(d, fb_ + i), hn::Load(d, fb_ + i + nl)};
        V fv[2];
        values_of_two<decltype(root)::value>(fc, k, a, b, fv);
        for (std::size_t h = 0; h < 2; ++h) {
          const std::size_t at = i + h * nl;
          // Steps done: the exit step, or N for an orbit that never decided (none for the
          // padding).
          steps = hn::Add(steps, hn::IfThenElse(hn::Lt(k[h], hn::Zero(d)), iters, k[h]));
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
          const V idx = hn::Load(d, fidx_ + at);
          const __mmask8 valid = _mm512_cmp_pd_mask(idx.raw, _mm512_setzero_pd(), _CMP_GE_OQ);
          const __m512i to = _mm512_cvttpd_epi64(idx.raw);
          if constexpr (decltype(single)::value)
            _mm512_mask_i64scatter_ps(out_float, valid, to, _mm512_cvtpd_ps(fv[h].raw), 4);
          else
            _mm512_mask_i64scatter_pd(out, valid, to, fv[h].raw, 8);
#else
          hn::Store(fv[h], d, f);
          const std::size_t m = at < count ? std::min(nl, count - at) : 0;
          for (std::size_t q = 0; q < m; ++q) {
            const auto to = static_cast<std::size_t>(fidx_[at + q]);
            if constexpr (decltype(single)::value)
              out_float[to] = static_cast<float>(f[q]);
            else
              out[to] = f[q];
          }
#endif
        }
      }
    };
    if (root_) {
      if (out_float)
        each(std::true_type{}, std::true_type{});
      else
        each(std::true_type{}, std::false_type{});
    } else {
      if (out_float)
        each(std::false_type{}, std::true_type{});
      else
        each(std::false_type{}, std::false_type{});
    }
    steps_ += static_cast<std::uint64_t>(hn::GetLane(hn::SumOfLanes(d, steps)));
    fcount_ = 0;
  }

  // One operation over all lanes.
  void apply(const KernelOp& op) {
    const Slot a = slot_[op.a], b = slot_[op.b], dst = slot_[op.dst];
    switch (op.code) {
      case OpCode::kLoad: {
        const Q l = broadcast(op.lit);
        each([&](std::size_t o) { dst.store(o, l); });
        break;
      }
      case OpCode::kNeg:
        each([&](std::size_t o) {
          const Q q = a.load(o);
          dst.store(o, {hn::Neg(q.w), hn::Neg(q.x), hn::Neg(q.y), hn::Neg(q.z)});
        });
        break;
      case OpCode::kConj:
        each([&](std::size_t o) {
          const Q q = a.load(o);
          dst.store(o, {q.w, hn::Neg(q.x), hn::Neg(q.y), hn::Neg(q.z)});
        });
        break;
      case OpCode::kInv:
        each([&](std::size_t o) { dst.store(o, inv(a.load(o))); });
        break;
      case OpCode::kNorm:
      case OpCode::kAbs: {
        const V zero = hn::Zero(D());
        const bool root = op.code == OpCode::kAbs;
        each([&](std::size_t o) {
          const V n2 = norm2(a.load(o));
          dst.store(o, {root ? hn::Sqrt(n2) : n2, zero, zero, zero});
        });
        break;
      }
      case OpCode::kSqr:
        with_add(op, [&](std::size_t o) { return sqr(a.load(o)); });
        break;
      case OpCode::kAdd:
        each([&](std::size_t o) { dst.store(o, add(a.load(o), b.load(o))); });
        break;
      case OpCode::kSub:
        each([&](std::size_t o) { dst.store(o, sub(a.load(o), b.load(o))); });
        break;
      case OpCode::kMul:
        with_add(op, [&](std::size_t o) { return mul(a.load(o), b.load(o)); });
        break;
      case OpCode::kDiv:
        each([&](std::size_t o) { dst.store(o, mul(a.load(o), inv(b.load(o)))); });
        break;
      case OpCode::kAddReal: {
        const V l = hn::Set(D(), op.lit.w);
        each([&](std::size_t o) {
          Q q = a.load(o);
          q.w = hn::Add(q.w, l);
          dst.store(o, q);
        });
        break;
      }
      case OpCode::kAddLit: {
        const Q l = broadcast(op.lit);
        each([&](std::size_t o) { dst.store(o, add(a.load(o), l)); });
        break;
      }
      case OpCode::kLitSub: {
        const Q l = broadcast(op.lit);
        each([&](std::size_t o) { dst.store(o, sub(l, a.load(o))); });
        break;
      }
      case OpCode::kScale: {
        const V l = hn::Set(D(), op.lit.w);
        with_add(op, [&](std::size_t o) { return scale(l, a.load(o)); });
        break;
      }
      case OpCode::kMulLit: {
        const Q l = broadcast(op.lit);
        with_add(op, [&](std::size_t o) { return mul(a.load(o), l); });
        break;
      }
      case OpCode::kLitMul: {
        const Q l = broadcast(op.lit);
        with_add(op, [&](std::size_t o) { return mul(l, a.load(o)); });
        break;
      }
      case OpCode::kLitDiv: {
        const Q l = broadcast(op.lit);
        each([&](std::size_t o) { dst.store(o, mul(l, inv(a.load(o)))); });
        break;
      }
      case OpCode::kScaleAddReal: {
        const V sc = hn::Set(D(), op.lit.w), t = hn::Set(D(), op.lit.x);
        each([&](std::size_t o) {
          Q q = scale(sc, a.load(o));
          q.w = hn::Add(q.w, t);
          dst.store(o, q);
        });
        break;
      }
      default:  // the analytic functions
        each([&](std::size_t o) { dst.store(o, analytic(op.code, a.load(o), op.lit.w)); });
        break;
    }
  }

  template <class F>
  HWY_INLINE void each(const F& f) {
    const std::size_t nl = hn::Lanes(D());
    for (std::size_t o = 0; o < lanes_; o += nl) f(o);
  }

  // dst = f(o), followed by the fused addition of the operation.
  template <class F>
  HWY_INLINE void with_add(const KernelOp& op, const F& product) {
    if (op.scale != 1) {
      const V sc = hn::Set(D(), op.scale);
      with_add_of(op, [&](std::size_t o) { return scale(sc, product(o)); });
    } else {
      with_add_of(op, product);
    }
  }

  template <class F>
  HWY_INLINE void with_add_of(const KernelOp& op, const F& f) {
    const Slot dst = slot_[op.dst];
    switch (op.add) {
      case 1: {
        const Q l = broadcast(op.add_lit);
        each([&](std::size_t o) { dst.store(o, add(f(o), l)); });
        break;
      }
      case 2: {
        const Slot r = slot_[op.add_reg];
        each([&](std::size_t o) { dst.store(o, add(f(o), r.load(o))); });
        break;
      }
      case 3: {
        const V l = hn::Set(D(), op.add_lit.w);
        each([&](std::size_t o) {
          Q q = f(o);
          q.w = hn::Add(q.w, l);
          dst.store(o, q);
        });
        break;
      }
      default:
        each([&](std::size_t o) { dst.store(o, f(o)); });
        break;
    }
  }

  const KernelSetup* s_ = nullptr;
  bool root_ = false;
  double* out_ = nullptr;
  float* out_float_ = nullptr;
  std::uint64_t steps_ = 0;
  std::size_t lanes_ = 0, live_ = 0;
  bool result_is_temp_ = false;
  std::vector<double> storage_;
  Slot slot_[kSlots];
  // Per lane: the sweep its orbit started in, previous and new metric (escape: |h|^2,
  // cut-off: |h_k - h_(k-1)|^2), point index; all-ones bits in frozen_ for a decided or idle
  // lane, in pending_ for a decided one; what F needs of a decided orbit.
  HWY_ALIGN double prev_buf_[kMaxInFlight + 8], metric_buf_[kMaxInFlight + 8];
  double* prev_ = prev_buf_;
  double* metric_ = metric_buf_;
  HWY_ALIGN double start_[kMaxInFlight + 8], idx_[kMaxInFlight + 8], ext_[kMaxInFlight + 8];
  HWY_ALIGN double frozen_[kMaxInFlight + 8], pending_[kMaxInFlight + 8];
  HWY_ALIGN double cap_code_[kMaxInFlight + 8], cap_a_[kMaxInFlight + 8], cap_b_[kMaxInFlight + 8];
  std::uint64_t sweeps_ = 0;
  bool any_pending_ = false;
  // Waiting points.
  std::vector<double> qh_[4], qc_[4], qidx_, qprev_;
  std::size_t queued_ = 0, taken_ = 0;
  // Finished orbits.
  // (Room for the padding to a pair of vectors.)
  HWY_ALIGN double fcode_[kFinished + 16], fa_[kFinished + 16], fb_[kFinished + 16],
      fidx_[kFinished + 16];
  std::size_t fcount_ = 0;
};

// This thread's machine: large, so kept per thread rather than on the stack.
Machine& thread_machine() {
  thread_local std::unique_ptr<Machine> machine;
  if (!machine) machine = std::make_unique<Machine>();
  return *machine;
}

std::uint64_t KernelField(const KernelSetup& s, const double* x, const double* y, const double* z,
                          std::size_t n, double* out, bool root) {
  return thread_machine().run(s, x, y, z, n, out, nullptr, root);
}

std::uint64_t KernelFieldFloat(const KernelSetup& s, const double* x, const double* y,
                               const double* z, std::size_t n, float* out, bool root) {
  return thread_machine().run(s, x, y, z, n, nullptr, out, root);
}

int KernelLoopOf(const KernelSetup& s) { return static_cast<int>(thread_machine().loop(s)); }

void KernelAnalytic(int code, const Quat* in, std::size_t n, double exponent, Quat* out) {
  const D d;
  const std::size_t nl = hn::Lanes(d);
  HWY_ALIGN double c[4][8];
  for (std::size_t i = 0; i < n; i += nl) {
    const std::size_t m = std::min(nl, n - i);
    for (std::size_t q = 0; q < nl; ++q)
      for (int k = 0; k < 4; ++k) c[k][q] = in[i + std::min(q, m - 1)][k];
    const Q v = analytic(
        static_cast<OpCode>(code),
        {hn::Load(d, c[0]), hn::Load(d, c[1]), hn::Load(d, c[2]), hn::Load(d, c[3])}, exponent);
    hn::Store(v.w, d, c[0]);
    hn::Store(v.x, d, c[1]);
    hn::Store(v.y, d, c[2]);
    hn::Store(v.z, d, c[3]);
    for (std::size_t q = 0; q < m; ++q) out[i + q] = Quat(c[0][q], c[1][q], c[2][q], c[3][q]);
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace qjulia::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace qjulia::detail {

HWY_EXPORT(KernelField);
HWY_EXPORT(KernelFieldFloat);
HWY_EXPORT(KernelAnalytic);
HWY_EXPORT(KernelLoopOf);

KernelLoop kernel_loop(const KernelSetup& setup) {
  return static_cast<KernelLoop>(HWY_DYNAMIC_DISPATCH(KernelLoopOf)(setup));
}

const char* to_string(KernelLoop loop) {
  switch (loop) {
    case KernelLoop::kSquare:
      return "square";
    case KernelLoop::kCubicOverSquare:
      return "cubic-over-square";
    case KernelLoop::kChain:
      return "chain";
    default:
      return "sweeps";
  }
}

std::vector<Quat> kernel_analytic(OpCode code, const std::vector<Quat>& in, double exponent) {
  std::vector<Quat> out(in.size());
  HWY_DYNAMIC_DISPATCH(KernelAnalytic)
  (static_cast<int>(code), in.data(), in.size(), exponent, out.data());
  return out;
}

namespace {

// The vector targets the kernel is compiled for, best first.
constexpr std::int64_t kVectorTargets = HWY_AVX3 | HWY_AVX2;

bool reads(const KernelOp& op, int r) {
  switch (op.code) {
    case OpCode::kLoad:
      return op.add == 2 && op.add_reg == r;
    case OpCode::kAdd:
    case OpCode::kSub:
    case OpCode::kMul:
    case OpCode::kDiv:
      return op.a == r || op.b == r || (op.add == 2 && op.add_reg == r);
    default:
      return op.a == r || (op.add == 2 && op.add_reg == r);
  }
}

// True when register r is not read after ops[from - 1] before it is written again, and is not
// the result.
bool dead_after(const std::vector<KernelOp>& ops, std::size_t from, int r, int result) {
  for (std::size_t j = from; j < ops.size(); ++j) {
    if (reads(ops[j], r)) return false;
    if (ops[j].dst == r) return true;
  }
  return r != result;
}

}  // namespace

void prepare_kernel(KernelSetup& s) {
  // The slice by additions (point_of()): each direction one unit axis of its own, its other
  // components +0 (a -0 would flip the sign of a zero term).
  s.axis_slice = true;
  std::fill(std::begin(s.axis_of), std::end(s.axis_of), -1);
  for (int a = 0; a < 3; ++a) {
    int one = -1, zeros = 0;
    for (int c = 0; c < 4; ++c) {
      if (s.dir[a][c] == 1.0) one = c;
      zeros += s.dir[a][c] == 0.0 && !std::signbit(s.dir[a][c]);
    }
    if (one < 0 || zeros != 3 || s.axis_of[one] >= 0)
      s.axis_slice = false;
    else
      s.axis_of[one] = a;
  }
  s.origin_negative_zero = 0;
  for (int c = 0; c < 4; ++c)
    if (s.origin[c] == 0.0 && std::signbit(s.origin[c])) s.origin_negative_zero |= 1u << c;
  std::vector<KernelOp> ops;
  for (int i = 0; i < s.op_count; ++i) {
    const Op& src = s.ops[i];
    KernelOp op{src.code, src.dst, src.a, src.b, src.lit, 0, 0, Quat()};
    const bool ua = s.uniform[op.a], ub = s.uniform[op.b];
    // A uniform register operand becomes a literal where the operation has a literal form;
    // the arithmetic is the same (x - y and x + (-y) round alike; a / b is a * inv(b)).
    switch (op.code) {
      case OpCode::kAdd:
        if (ub)
          op = {OpCode::kAddLit, op.dst, op.a, 0, s.init[op.b], 0, 0, Quat()};
        else if (ua)
          op = {OpCode::kAddLit, op.dst, op.b, 0, s.init[op.a], 0, 0, Quat()};
        break;
      case OpCode::kSub:
        if (ub)
          op = {OpCode::kAddLit, op.dst, op.a, 0, -s.init[op.b], 0, 0, Quat()};
        else if (ua)
          op = {OpCode::kLitSub, op.dst, op.b, 0, s.init[op.a], 0, 0, Quat()};
        break;
      case OpCode::kMul:
        if (ub)
          op = {OpCode::kMulLit, op.dst, op.a, 0, s.init[op.b], 0, 0, Quat()};
        else if (ua)
          op = {OpCode::kLitMul, op.dst, op.b, 0, s.init[op.a], 0, 0, Quat()};
        break;
      case OpCode::kDiv:
        if (ub)
          op = {OpCode::kMulLit, op.dst, op.a, 0, inv(s.init[op.b]), 0, 0, Quat()};
        else if (ua)
          op = {OpCode::kLitDiv, op.dst, op.b, 0, s.init[op.a], 0, 0, Quat()};
        break;
      default:
        break;
    }
    ops.push_back(op);
  }
  // Fuse a real factor and an addition into the square or product before them when that
  // product is not read again: h^2 + c, p*h^2 + q, 2*h^3 + 1, 3*h^2; the addition also after a
  // fused factor (0.5*h^2 + c).
  std::vector<KernelOp> fused;
  for (std::size_t i = 0; i < ops.size(); ++i) {
    KernelOp op = ops[i];
    const bool product = op.code == OpCode::kSqr || op.code == OpCode::kMul ||
                         op.code == OpCode::kMulLit || op.code == OpCode::kLitMul ||
                         op.code == OpCode::kScale;
    if (product && i + 1 < ops.size()) {
      const KernelOp& next = ops[i + 1];
      const int t = op.dst;
      const bool dead = next.dst == t || dead_after(ops, i + 2, t, s.result);
      if (dead && next.a == t &&
          (next.code == OpCode::kScale || next.code == OpCode::kScaleAddReal)) {
        op.scale = next.lit.w;
        if (next.code == OpCode::kScaleAddReal) {
          op.add = 3;
          op.add_lit = Quat(next.lit.x);
        }
        op.dst = next.dst;
        ++i;
      }
    }
    if (product && op.add == 0 && i + 1 < ops.size()) {
      const KernelOp& next = ops[i + 1];
      const int t = op.dst;
      int other = -1;
      int kind = 0;
      if (next.code == OpCode::kAddLit && next.a == t) kind = 1;
      if (next.code == OpCode::kAddReal && next.a == t) kind = 3;
      if (next.code == OpCode::kAdd && next.a == t && next.b != t) kind = 2, other = next.b;
      if (next.code == OpCode::kAdd && next.b == t && next.a != t) kind = 2, other = next.a;
      // The product is not read again: the addition overwrites it, or nothing reads it.
      if (kind != 0 && (next.dst == t || dead_after(ops, i + 2, t, s.result))) {
        op.add = static_cast<std::uint8_t>(kind);
        op.add_lit = next.lit;
        op.add_reg = static_cast<std::uint8_t>(kind == 2 ? other : 0);
        op.dst = next.dst;
        ++i;
      }
    }
    fused.push_back(op);
  }
  s.kops = std::move(fused);
}

std::vector<std::string> kernel_targets() {
  std::vector<std::string> out;
  for (std::int64_t t : hwy::SupportedAndGeneratedTargets())
    if (t & kVectorTargets) out.push_back(hwy::TargetName(t));
  return out;
}

std::vector<std::int64_t> kernel_dispatch_targets() {
  std::vector<std::int64_t> out;
  for (std::int64_t t : hwy::SupportedAndGeneratedTargets())
    if (t & kVectorTargets) out.push_back(t);
  return out;
}

std::string kernel_target() {
  const std::int64_t best = hwy::SupportedTargets() & HWY_TARGETS & kVectorTargets;
  if (best == 0) return "scalar";
  return hwy::TargetName(best & -best);
}

bool kernel_supports(const Op*, int) { return true; }

std::uint64_t kernel_field(const KernelSetup& setup, const double* x, const double* y,
                           const double* z, std::size_t n, double* out, bool root) {
  if (n == 0) return 0;
  return HWY_DYNAMIC_DISPATCH(KernelField)(setup, x, y, z, n, out, root);
}

std::uint64_t kernel_field(const KernelSetup& setup, const double* x, const double* y,
                           const double* z, std::size_t n, float* out, bool root) {
  if (n == 0) return 0;
  return HWY_DYNAMIC_DISPATCH(KernelFieldFloat)(setup, x, y, z, n, out, root);
}

}  // namespace qjulia::detail
#endif  // HWY_ONCE
