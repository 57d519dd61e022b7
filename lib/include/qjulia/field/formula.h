#pragma once
/// @file formula.h
/// Quaternion formulas: parse once, evaluate fast.
///
/// Grammar (whitespace ignored):
///   expr    := term (('+' | '-') term)*
///   term    := unary (('*' | '/') unary)*          a/b means a * b^-1 (right division)
///   unary   := '-' unary | power                   -h^2 = -(h^2); there is no unary '+'
///   power   := primary ('^' ['-'] number)?         a literal real exponent x, |x| <= 64; an
///                                                  integer value (2, 2.0, 2e0) is a power by
///                                                  squaring (h^-2 = inv(h^2), h^0 = 1), any
///                                                  other a real power exp(x log h); powers
///                                                  do not chain (write (h^0.5)^2)
///   primary := number | quaternion literal | name | func '(' expr ')' | '(' expr ')'
///   number  := decimal real, e.g. 2, 0.5, 1e-3, .5; the imaginary units i, j, k may follow a
///              number directly (3i, 0.5k) or stand alone (i, j, k)
///   quaternion literal := '[' real ',' real ',' real ',' real ']'  (w, x, y, z; each real may
///              carry a sign)
///   func    := conj | inv | norm (|q|^2 as a real quaternion) | abs (|q|) | sqr
///              | exp | log | sqrt | sin | cos | tan | sinh | cosh | tanh
/// The analytic functions and real powers extend the complex ones: q = a + t u (t = |vector
/// part|, u its direction, u = i when t = 0) behaves as the complex a + t i, so log, sqrt and
/// real powers are principal branches and give log(-1) = pi i, sqrt(-4) = 2i (docs/formula.md
/// lists domains, poles and costs).
/// Names are the variable `h` and any constant given to compile(). Products are evaluated in
/// the order written: p*h^2 multiplies p on the left. There is no implicit multiplication:
/// `2h` and `3 i` are errors, only the number-unit form `3i` is one token.
/// Division by a zero quaternion is not an error: it yields non-finite components, and so do
/// the other poles (log 0, 0^-1.5) and overflow (exp(800)).
/// Limits: 4096 characters, 64 nested parentheses/calls/signs, 32 registers (h, the constants
/// used and intermediate values); beyond them compile() throws InvalidInput.
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "qjulia/field/quaternion.h"

namespace qjulia {

/// A compiled formula f(h; constants). Cheap to copy (shares the program); evaluation is
/// thread-safe and allocation-free.
class Formula {
 public:
  /// The identity formula f(h) = h with no constants.
  Formula();

  /// Parses and compiles `text`.
  /// @param[in] text  the formula, e.g. "(2*h^3+1)/(3*h^2)"
  /// @param[in] constant_names  names that may appear as constants, in the order of the values
  ///                            passed to eval(); the name "h" is reserved for the variable.
  /// @throws InvalidInput with "formula LINE:COL: expected ..." naming the 1-based line (1 for
  ///         one-line text) and column of the offending token and what was expected, or
  ///         "formula 1:5: unknown name 'x' (known: h, c, p)"; also when a constant name is not
  ///         an identifier, is repeated, or is reserved (h, i, j, k, a function name).
  static Formula compile(const std::string& text, const std::vector<std::string>& constant_names);

  /// f(h) with the constants' values in the order of constant_names. No allocation, no
  /// exceptions; a pole gives non-finite components.
  /// @param[in] constants  pointer to constant_names().size() quaternions (may be null when
  ///                       the formula uses no constant)
  Quat eval(const Quat& h, const Quat* constants) const;

  /// The source text.
  const std::string& text() const;
  /// The constant names given to compile().
  const std::vector<std::string>& constant_names() const;
  /// Which constants the formula actually uses (same order as constant_names()): those whose
  /// name appears in the text.
  const std::vector<bool>& constants_used() const;
  /// True when every literal written in the text is real (no i, j, k, no quaternion literal
  /// with a non-zero imaginary part), every literal-only part folds to a real value (not
  /// sqrt(-1) or log(-2)) and every used constant has a zero imaginary part. Then
  /// f(u h u^-1) = u f(h) u^-1 for unit quaternions u: f commutes with rotations of the
  /// imaginary part (the rotation-symmetry facts of docs/design.md), except where log, sqrt or a
  /// real power meets a negative real value, where the axis i is taken.
  /// @param[in] constants  constant_names().size() quaternions, as for eval()
  bool has_real_coefficients(const Quat* constants) const;
  /// Number of register operations one eval() runs (h^3 takes 2; literal-only parts fold to 0).
  std::size_t operation_count() const;

  struct Program;  ///< the compiled form (internal: lib/src/field/program.h)
  /// The compiled program, for the evaluators.
  const Program& program() const { return *program_; }

 private:
  std::shared_ptr<const Program> program_;
};

}  // namespace qjulia
