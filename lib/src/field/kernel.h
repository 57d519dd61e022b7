#pragma once
// The field F of the classifier over batches of points: the formula's register program runs in
// SIMD lanes (Highway, dispatched at run time to AVX-512 or AVX2), each lane one orbit; a lane
// whose orbit has decided is retired and refilled with the next point so the vectors stay full.
// F itself (two logarithms and a ratio) is computed afterwards for the whole batch. Without
// AVX2, or for programs the vector code does not cover, the scalar Classifier is the path.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "field/program.h"
#include "qjulia/field/params.h"
#include "qjulia/field/quaternion.h"

namespace qjulia::detail {

/// The kernel's form of a program operation: the formula's operations with constants that are
/// the same in every lane turned into literals, and an addition that follows a square or a
/// product fused into it (the scalar evaluator runs the same arithmetic as two operations).
struct KernelOp {
  OpCode code;  ///< the operation (kAddReal, kAddLit, kMulLit, ... for literal operands)
  std::uint8_t dst, a, b;
  Quat lit;  ///< the literal operand
  /// A fused addition after the operation: 0 none, 1 + add_lit, 2 + register add_reg, 3 + the
  /// real add_lit.w (to the real part only).
  std::uint8_t add = 0;
  std::uint8_t add_reg = 0;
  Quat add_lit;
  /// A fused real factor applied after the operation, before the addition (1: none).
  double scale = 1;
};

/// Everything the vector kernel needs, as plain data (built once per Classifier).
struct KernelSetup {
  const Op* ops = nullptr;
  int op_count = 0;
  int result = 0;           ///< register holding f(h) after the ops
  int registers = 1;        ///< registers the program uses (h, constants, temporaries)
  Quat init[kRegisters];    ///< initial values of the constant registers (1 .. registers-1)
  bool mandelbrot = false;  ///< the point is `c` and h0 = start (else h0 is the point)
  int c_register = -1;      ///< Mandelbrot: the register of `c` (-1 when the formula has no c)
  Quat start;               ///< Mandelbrot: h0
  Quat origin;              ///< slice: h0 = origin + x d[0] + y d[1] + z d[2]
  Quat dir[3];
  /// The slice by additions (prepare_kernel() sets it): true when each direction is a unit
  /// axis of its own (one component 1, the others +0); then component c of the point is the
  /// coordinate axis_of[c] (0..2; -1: none) plus origin[c], bit for bit what the fused form
  /// computes for finite coordinates (its other terms add zeros; see point_of() in kernel.cpp
  /// for an origin component of -0, origin_negative_zero bit c).
  bool axis_slice = false;
  int axis_of[4] = {-1, -1, -1, -1};
  unsigned origin_negative_zero = 0;
  bool escape = true;  ///< escape method (else cut-off)
  int iterations = 1;  ///< N
  double r2 = 1;       ///< R^2
  double log_r = 0;    ///< log R
  /// The program in kernel form (prepare_kernel() builds it from ops).
  std::vector<KernelOp> kops;
  /// For each register: true when every lane holds the same value (h and a Mandelbrot c do
  /// not; the constants do).
  bool uniform[kRegisters] = {};
};

/// Builds setup.kops from setup.ops: literal operands for uniform registers, fused additions.
void prepare_kernel(KernelSetup& setup);

/// The raw outcome of one orbit, from which F follows (see finalize_field).
///   escape: step = exit step n (0..N) or -1 if it never left; a = |h_n|^2 (|h_N|^2 if never),
///           b = |h_(n-1)|^2.
///   cut-off: step = convergence step n (1..N), -1 if it never converged, -2 for a pole; a =
///           |h_n - h_(n-1)|^2 (of step N if never), b = the same of step n - 1.
struct RawOrbit {
  std::vector<std::int32_t> step;
  std::vector<double> a, b;
  void resize(std::size_t n) {
    step.resize(n);
    a.resize(n);
    b.resize(n);
  }
};

/// The names of the vector targets this build can dispatch to on this CPU, best first (empty
/// without AVX2).
std::vector<std::string> kernel_targets();
/// The vector targets of kernel_targets() as Highway target bits: for tests, with
/// hwy::SetSupportedTargetsForTest.
std::vector<std::int64_t> kernel_dispatch_targets();
/// The target kernel_field() uses now ("AVX3", "AVX2" or "scalar").
std::string kernel_target();
/// True when the vector kernel covers every operation of the program.
bool kernel_supports(const Op* ops, int op_count);

/// Runs the orbits of n points (slice coordinates x[i], y[i], z[i]) on the best vector target
/// and writes F (in double precision, clamped like the scalar classifier's) to out[i]. Returns
/// the number of formula evaluations (orbit steps) done. Requires kernel_supports(); without a
/// vector target it runs Highway's scalar emulation.
/// With `root`, writes the refinement value instead (see Classifier::root_field).
std::uint64_t kernel_field(const KernelSetup& setup, const double* x, const double* y,
                           const double* z, std::size_t n, double* out, bool root = false);
/// The same values rounded to float (as static_cast<float> rounds them), written directly.
std::uint64_t kernel_field(const KernelSetup& setup, const double* x, const double* y,
                           const double* z, std::size_t n, float* out, bool root = false);

/// How the vector kernel runs a program's orbits: on AVX-512 and AVX2 in registers for one square
/// of h plus an addition (h^2 + c), Newton's maps of a cubic ((s h^3 + a) / (t h^2)) and chains
/// of up to three operations with literal operands; any other program, and every program on
/// other targets, through the general sweeps (each operation over all lanes in memory).
enum class KernelLoop { kSquare, kCubicOverSquare, kChain, kSweeps };
/// The loop kernel_field() takes for setup's program on the current target (for tests).
KernelLoop kernel_loop(const KernelSetup& setup);
const char* to_string(KernelLoop loop);

/// One analytic function (kExp .. kPowReal, the exponent for the latter) on each quaternion, by
/// the vector code of the current target: for testing it against the scalar functions.
std::vector<Quat> kernel_analytic(OpCode code, const std::vector<Quat>& in, double exponent);

}  // namespace qjulia::detail
