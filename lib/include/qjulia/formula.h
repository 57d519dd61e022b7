#pragma once
/// @file formula.h
/// Quaternion formulas: parse once, evaluate fast.
///
/// Grammar (whitespace ignored):
///   expr    := term (('+' | '-') term)*
///   term    := unary (('*' | '/') unary)*          a/b means a * b^-1 (right division)
///   unary   := '-' unary | power
///   power   := primary ('^' ['-'] integer)?        integer powers by squaring; h^-2 = inv(h^2)
///   primary := number | quaternion literal | name | func '(' expr ')' | '(' expr ')'
///   number  := decimal real, e.g. 2, 0.5, 1e-3; the imaginary units i, j, k may follow a number
///              (3i, 0.5k) or stand alone (i, j, k)
///   quaternion literal := '[' real ',' real ',' real ',' real ']'  (w, x, y, z)
///   func    := conj | inv | norm (|q|^2 as a real quaternion) | abs (|q|) | sqr
/// Names are the variable `h` and any constant given to compile(). Products are evaluated in
/// the order written: p*h^2 multiplies p on the left.
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "qjulia/quaternion.h"

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
  /// @throws InvalidInput with "formula 1:COL: expected ..." naming the 1-based column and what
  ///         was expected, or naming an unknown identifier.
  static Formula compile(const std::string& text, const std::vector<std::string>& constant_names);

  /// f(h) with the constants' values in the order of constant_names.
  /// @param[in] constants  pointer to constant_names().size() quaternions
  Quat eval(const Quat& h, const Quat* constants) const;

  /// The source text.
  const std::string& text() const;
  /// The constant names given to compile().
  const std::vector<std::string>& constant_names() const;
  /// Which constants the formula actually uses (same order as constant_names()).
  const std::vector<bool>& constants_used() const;
  /// True when every literal and constant used is real and the formula uses only h, so it
  /// commutes with rotations about the real axis (the rotation-symmetry facts of DESIGN.md).
  bool has_real_coefficients(const Quat* constants) const;
  /// Number of register operations one eval() runs (h^3 takes 2; literal-only parts fold to 0).
  std::size_t operation_count() const;

  struct Program;  ///< the compiled form (internal)

 private:
  std::shared_ptr<const Program> program_;
};

}  // namespace qjulia
