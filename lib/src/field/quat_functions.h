#pragma once
// Analytic functions of one quaternion, the scalar reference of the formula language.
//
// Every function extends a complex function by the complex-plane rule: q = a + v with v the
// vector part, t = |v| and u = v/t, lies in the plane span{1, u}, where it behaves as the
// complex number a + t i; f(q) = X + Y u for f(a + t i) = X + Y i. When t = 0 the axis is
// undefined and u = i is taken, so log, sqrt and real powers of a negative real number give the
// complex answer (log(-1) = pi i, sqrt(-4) = 2i), not NaN. Since t >= 0, branch cuts of the
// complex function on the negative real axis are approached from above: on the cut itself the
// value is the limit from Im z > 0.
//
// The functions are accurate to a few ulp of |f(q)| (plus the condition of f at q for inputs
// that are themselves rounded) across the finite range; they never throw and never allocate.
// A pole or an overflow gives non-finite components (inf, or NaN where inf meets a zero
// factor), which the escape and cut-off methods treat as a pole. Non-finite input gives
// non-finite output. formula.cpp folds literal-only calls with exactly these functions and
// evaluates them per point; the batched evaluator calls them for lanes outside its ranges.
#include "qjulia/field/quaternion.h"

namespace qjulia {
namespace detail {

/// exp(q) = e^a (cos t + u sin t). Entire. Overflows (non-finite components) for a above about
/// 709.78 unless cos t, sin t are small enough to keep e^a cos t, e^a sin t finite.
Quat qexp(const Quat& q);

/// log(q) = log|q| + u atan2(t, a), the principal branch: the u part lies in [0, pi]. Defined
/// for q != 0; log(0) has real part -inf (a pole). The cut is the negative real axis, where
/// log(a) = log|a| + pi i.
Quat qlog(const Quat& q);

/// sqrt(q), the principal square root (real part >= 0): sqrt(q)^2 = q. Entire in value (finite
/// for every finite q), cut on the negative real axis, where sqrt(a) = sqrt(-a) i.
Quat qsqrt(const Quat& q);

/// sin(q) = sin a cosh t + u cos a sinh t. Entire; overflows for t above about 710.
Quat qsin(const Quat& q);

/// cos(q) = cos a cosh t - u sin a sinh t. Entire; overflows for t above about 710.
Quat qcos(const Quat& q);

/// tan(q) = sin(q) / cos(q) (the two commute). Poles at the real points pi/2 + n pi, which are
/// not doubles: there tan gives large finite values (about 1e16). Tends to u as t grows; never
/// overflows for finite q.
Quat qtan(const Quat& q);

/// sinh(q) = sinh a cos t + u cosh a sin t. Entire; overflows for |a| above about 710.
Quat qsinh(const Quat& q);

/// cosh(q) = cosh a cos t + u sinh a sin t. Entire; overflows for |a| above about 710.
Quat qcosh(const Quat& q);

/// tanh(q) = sinh(q) / cosh(q). Poles at the points (pi/2 + n pi) u with a = 0 (large finite
/// values, as for tan). Tends to +-1 as |a| grows; never overflows for finite q.
Quat qtanh(const Quat& q);

/// q^x = exp(x log q) = |q|^x (cos(x theta) + u sin(x theta)) with theta = atan2(t, a), for a
/// real exponent x: the principal branch, cut on the negative real axis (where the value is
/// |a|^x (cos(x pi) + i sin(x pi))). 0^x is 0 for x > 0 and +inf (a pole) for x < 0.
Quat qpow(const Quat& q, double x);

}  // namespace detail
}  // namespace qjulia
