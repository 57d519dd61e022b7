#pragma once
// The compiled form of a formula: a flat list of register operations. formula.cpp builds it and
// runs it one point at a time (the scalar reference); kernel.cpp runs it over batches of
// points in SIMD lanes. Both read exactly this description, so they evaluate the same program.
#include <cstdint>
#include <string>
#include <vector>

#include "qjulia/field/formula.h"
#include "qjulia/field/quaternion.h"

namespace qjulia {
namespace detail {

/// Registers of a program: 0 = h, 1.. = the used constants, then temporaries.
constexpr int kRegisters = 32;

/// One register operation: regs[dst] = f(regs[a], regs[b], lit). Operands are read before the
/// destination is written, so dst may equal a or b.
enum class OpCode : std::uint8_t {
  kLoad,          // lit
  kNeg,           // -a
  kConj,          // conj(a)
  kInv,           // inv(a)
  kNorm,          // |a|^2
  kAbs,           // |a|
  kSqr,           // a*a
  kAdd,           // a + b
  kSub,           // a - b
  kMul,           // a * b
  kDiv,           // a * inv(b)
  kAddReal,       // a + lit.w (lit real)
  kAddLit,        // a + lit
  kLitSub,        // lit - a
  kScale,         // lit.w * a (lit real: a real factor commutes)
  kMulLit,        // a * lit
  kLitMul,        // lit * a
  kLitDiv,        // lit * inv(a)
  kScaleAddReal,  // lit.w * a + lit.x (both real): kScale fused with the kAddReal after it
  // Analytic functions, each by the complex-plane rule: a = s + t u with t = |vector part| and
  // u its direction (u = i when t = 0) behaves as the complex number s + t i.
  kExp,      // exp(a)
  kLog,      // log(a), principal branch
  kSqrt,     // sqrt(a), principal branch
  kSin,      // sin(a)
  kCos,      // cos(a)
  kTan,      // tan(a)
  kSinh,     // sinh(a)
  kCosh,     // cosh(a)
  kTanh,     // tanh(a)
  kPowReal,  // a^lit.w for a real, non-integer exponent: exp(lit.w * log(a))
};

struct Op {
  OpCode code;
  std::uint8_t dst, a, b;
  Quat lit;
};

}  // namespace detail

struct Formula::Program {
  std::string text;
  std::vector<std::string> constant_names;
  std::vector<bool> used;                // per constant name
  std::vector<std::uint8_t> used_index;  // constants copied to registers 1, 2, ...
  std::vector<detail::Op> ops;
  std::uint8_t result = 0;    // register holding f(h) after the ops ran
  bool real_literals = true;  // every literal written in the text is real
};

}  // namespace qjulia
