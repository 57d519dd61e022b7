// Tests of the formula compiler: every expected value is computed by hand with the quaternion.h
// operators, never copied from output.
#include "qjulia/field/formula.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "field/quat_functions.h"
#include "qjulia/base/error.h"

namespace qjulia {
namespace {

const Quat kH(0.3, -0.7, 0.4, 1.1);
const Quat kP(0.5, 1.0, -2.0, 0.25);
const Quat kQ(-1.0, 0.2, 0.6, -0.9);

double distance(const Quat& a, const Quat& b) { return abs(a - b); }

void expect_near(const Quat& actual, const Quat& expected, double tolerance = 1e-12) {
  EXPECT_LE(distance(actual, expected), tolerance * (1 + abs(expected)))
      << "actual (" << actual.w << ", " << actual.x << ", " << actual.y << ", " << actual.z
      << ") expected (" << expected.w << ", " << expected.x << ", " << expected.y << ", "
      << expected.z << ")";
}

/// f(h) for a formula in h, p, q.
Quat eval_hpq(const std::string& text, const Quat& h = kH) {
  const Formula f = Formula::compile(text, {"p", "q"});
  const Quat constants[] = {kP, kQ};
  return f.eval(h, constants);
}

/// The message of the InvalidInput compile() throws, or "" when it compiles.
std::string compile_error(const std::string& text,
                          const std::vector<std::string>& constants = {"c", "p"}) {
  try {
    Formula::compile(text, constants);
  } catch (const InvalidInput& e) {
    return e.what();
  }
  return "";
}

Quat repeated_product(const Quat& h, int n) {
  Quat r(1);
  for (int k = 0; k < (n < 0 ? -n : n); ++k) r = r * h;
  return n < 0 ? inv(r) : r;
}

TEST(Formula, MultiplicationBindsTighterThanAdditionAndPowerTighterStill) {
  expect_near(eval_hpq("h + p*h^2 - q"), (kH + kP * (kH * kH)) - kQ);
  expect_near(eval_hpq("p*h + q*h"), kP * kH + kQ * kH);
  expect_near(eval_hpq("(h + p)*q"), (kH + kP) * kQ);
  expect_near(eval_hpq("p*(h + q)^3"), kP * ((kH + kQ) * (kH + kQ) * (kH + kQ)));
}

TEST(Formula, OperatorsOfEqualPrecedenceAssociateToTheLeft) {
  expect_near(eval_hpq("h - p - q"), (kH - kP) - kQ);
  expect_near(eval_hpq("h*p*q"), (kH * kP) * kQ);
  expect_near(eval_hpq("h/p/q"), (kH * inv(kP)) * inv(kQ));
  expect_near(eval_hpq("h/p*q"), (kH * inv(kP)) * kQ);
  expect_near(eval_hpq("h*p/q"), (kH * kP) * inv(kQ));
}

TEST(Formula, ProductsKeepTheWrittenOrder) {
  const Quat left = eval_hpq("p*h");
  const Quat right = eval_hpq("h*p");
  expect_near(left, kP * kH);
  expect_near(right, kH * kP);
  EXPECT_GT(distance(left, right), 0.1);  // p is not real, so the order matters
  expect_near(eval_hpq("p*h^2 + q"), kP * (kH * kH) + kQ);
  EXPECT_GT(distance(eval_hpq("p*h^2 + q"), eval_hpq("h^2*p + q")), 0.1);
}

TEST(Formula, IntegerPowersEqualRepeatedMultiplication) {
  for (int n = -5; n <= 12; ++n) {
    SCOPED_TRACE("n = " + std::to_string(n));
    expect_near(eval_hpq("h^" + std::to_string(n)), repeated_product(kH, n), 1e-12);
    expect_near(eval_hpq("(h + p)^" + std::to_string(n)), repeated_product(kH + kP, n), 1e-12);
  }
}

TEST(Formula, PowersAreComputedBySquaring) {
  EXPECT_EQ(Formula::compile("h^2", {}).operation_count(), 1u);   // sqr
  EXPECT_EQ(Formula::compile("h^3", {}).operation_count(), 2u);   // sqr, mul
  EXPECT_EQ(Formula::compile("h^8", {}).operation_count(), 3u);   // sqr, sqr, sqr
  EXPECT_EQ(Formula::compile("h^-2", {}).operation_count(), 2u);  // sqr, inv
  EXPECT_EQ(Formula::compile("h^64", {}).operation_count(), 6u);
  EXPECT_EQ(Formula::compile("h^1", {}).operation_count(), 0u);
  expect_near(eval_hpq("h^0"), Quat(1));
  expect_near(eval_hpq("h^2"), sqr(kH), 0);
}

TEST(Formula, DivisionIsRightDivision) {
  expect_near(eval_hpq("h/p"), kH * inv(kP));
  EXPECT_GT(distance(eval_hpq("h/p"), inv(kP) * kH), 0.1);
  expect_near(eval_hpq("2/h"), 2.0 * inv(kH));
  expect_near(eval_hpq("p/h"), kP * inv(kH));
  expect_near(eval_hpq("h/2"), 0.5 * kH);
  expect_near(eval_hpq("h/[0,1,0,0]"), kH * inv(Quat(0, 1, 0, 0)));
}

TEST(Formula, UnaryMinusBindsLooserThanPower) {
  expect_near(eval_hpq("-h^2"), -(kH * kH));
  expect_near(eval_hpq("(-h)^3"), -(kH * kH * kH));
  expect_near(eval_hpq("-h*p"), (-kH) * kP);
  expect_near(eval_hpq("h - -h"), 2.0 * kH);
  expect_near(eval_hpq("p*-h"), kP * (-kH));
  expect_near(eval_hpq("--h"), kH);
  expect_near(eval_hpq("-2^2"), Quat(-4));
}

TEST(Formula, ReadsUnitsAndLiterals) {
  expect_near(eval_hpq("3i"), Quat(0, 3, 0, 0), 0);
  expect_near(eval_hpq("0.8i + .5j - 2.5k"), Quat(0, 0.8, 0.5, -2.5), 0);
  expect_near(eval_hpq("i"), Quat(0, 1, 0, 0), 0);
  expect_near(eval_hpq("2"), Quat(2), 0);
  expect_near(eval_hpq(".5"), Quat(0.5), 0);
  expect_near(eval_hpq("1e-3"), Quat(1e-3), 0);
  expect_near(eval_hpq("2.5E+2"), Quat(250), 0);
  expect_near(eval_hpq("[1, -2, 3e-1, +4]"), Quat(1, -2, 0.3, 4), 0);
  expect_near(eval_hpq("i*j"), Quat(0, 0, 0, 1), 0);
  expect_near(eval_hpq("j*i"), Quat(0, 0, 0, -1), 0);
  expect_near(eval_hpq("i^2"), Quat(-1), 0);
  expect_near(eval_hpq("i*j*k"), Quat(-1), 0);
  expect_near(eval_hpq("h + 3i"), kH + Quat(0, 3, 0, 0));
  expect_near(eval_hpq("2i*h"), Quat(0, 2, 0, 0) * kH);
  expect_near(eval_hpq("h*2i"), kH * Quat(0, 2, 0, 0));
  expect_near(eval_hpq("1 - h"), Quat(1) - kH);
  expect_near(eval_hpq("k - h"), Quat(0, 0, 0, 1) - kH);
  expect_near(eval_hpq(" h\t+\n1 "), kH + Quat(1));
}

TEST(Formula, FoldsLiteralOnlySubexpressions) {
  const Formula f = Formula::compile("(2*3 + 1)/2 + i^2", {});
  EXPECT_EQ(f.operation_count(), 1u);  // one load of the folded value
  expect_near(f.eval(kH, nullptr), Quat(2.5), 0);
  EXPECT_EQ(Formula::compile("h*(2*3)", {}).operation_count(), 1u);
  EXPECT_EQ(Formula::compile("h", {}).operation_count(), 0u);
}

TEST(Formula, AppliesTheFunctions) {
  expect_near(eval_hpq("conj(h)"), conj(kH), 0);
  expect_near(eval_hpq("inv(h)"), inv(kH), 0);
  expect_near(eval_hpq("norm(h)"), Quat(norm2(kH)), 0);
  expect_near(eval_hpq("abs(h)"), Quat(abs(kH)), 0);
  expect_near(eval_hpq("sqr(h + p)"), sqr(kH + kP), 0);
  expect_near(eval_hpq("inv(h)*h"), Quat(1));
  expect_near(eval_hpq("p*conj(h)^2"), kP * sqr(conj(kH)));
  expect_near(eval_hpq("abs(3i + 4j)"), Quat(5), 0);
}

TEST(Formula, AppliesTheAnalyticFunctionsAndFoldsThemWithTheSameCode) {
  const std::pair<const char*, Quat (*)(const Quat&)> functions[] = {
      {"exp", detail::qexp},   {"log", detail::qlog},   {"sqrt", detail::qsqrt},
      {"sin", detail::qsin},   {"cos", detail::qcos},   {"tan", detail::qtan},
      {"sinh", detail::qsinh}, {"cosh", detail::qcosh}, {"tanh", detail::qtanh}};
  for (const auto& [name, f] : functions) {
    SCOPED_TRACE(name);
    const std::string call = std::string(name) + "(";
    expect_near(eval_hpq(call + "h)"), f(kH), 0);
    expect_near(eval_hpq(call + "p*h + q)"), f(kP * kH + kQ), 0);
    expect_near(eval_hpq("q*" + call + "h)^2"), kQ * sqr(f(kH)), 0);
    EXPECT_EQ(Formula::compile(call + "h)", {}).operation_count(), 1u);
    // A literal-only call is folded at compile time by the same function: one load.
    const Formula folded = Formula::compile(call + "[0.3, -0.7, 0.4, 1.1])", {});
    EXPECT_EQ(folded.operation_count(), 1u);
    expect_near(folded.eval(Quat(5), nullptr), f(kH), 0);
  }
}

TEST(Formula, RealExponentsAreRealPowersAndIntegerValuesKeepRepeatedSquaring) {
  for (double x : {1.5, -1.5, 0.5, 0.25, 2.5, -0.1, 63.5}) {
    std::ostringstream text;
    text << std::setprecision(17) << "h^" << x;
    SCOPED_TRACE(text.str());
    expect_near(eval_hpq(text.str()), detail::qpow(kH, x), 0);
    EXPECT_EQ(Formula::compile(text.str(), {}).operation_count(), 1u);
  }
  expect_near(eval_hpq("(h + p)^.5"), detail::qpow(kH + kP, 0.5), 0);
  expect_near(eval_hpq("h^1e-1"), detail::qpow(kH, 0.1), 0);
  expect_near(eval_hpq("-h^0.5"), -detail::qpow(kH, 0.5), 0);  // -(h^0.5)
  expect_near(eval_hpq("(h^0.5)^2"), kH, 1e-15);
  expect_near(eval_hpq("h^0.5"), detail::qsqrt(kH), 1e-15);
  expect_near(eval_hpq("h^1.5"), kH * detail::qsqrt(kH), 1e-15);
  expect_near(eval_hpq("h^-1.5*h^1.5"), Quat(1), 1e-15);
  // An integer value, however written, is an integer power: exact repeated squaring.
  EXPECT_EQ(Formula::compile("h^2.0", {}).operation_count(), 1u);
  expect_near(eval_hpq("h^2.0"), sqr(kH), 0);
  expect_near(eval_hpq("h^3e0"), eval_hpq("h^3"), 0);
  expect_near(eval_hpq("h^-2.0"), eval_hpq("h^-2"), 0);
  expect_near(eval_hpq("h^64.0"), eval_hpq("h^64"), 0);
  expect_near(eval_hpq("h^0.0"), Quat(1), 0);
  // Literal bases fold with the same function.
  const Formula f = Formula::compile("2^0.5*h", {});
  EXPECT_EQ(f.operation_count(), 1u);
  expect_near(f.eval(kH, nullptr), detail::qpow(Quat(2), 0.5).w * kH, 0);
}

TEST(Formula, LogsRootsAndRealPowersOfNegativeRealsAreComplex) {
  const double pi = std::acos(-1.0);
  expect_near(Formula::compile("sqrt(-4)", {}).eval(kH, nullptr), Quat(0, 2, 0, 0), 0);
  expect_near(Formula::compile("log(h)", {}).eval(Quat(-1), nullptr), Quat(0, pi, 0, 0), 0);
  expect_near(Formula::compile("h^0.5", {}).eval(Quat(-4), nullptr), Quat(0, 2, 0, 0), 1e-15);
  expect_near(Formula::compile("h^1.5", {}).eval(Quat(-4), nullptr), Quat(0, -8, 0, 0), 1e-15);
  // A folded value that is not real is a coefficient that is not real, though written in reals.
  EXPECT_FALSE(Formula::compile("h + sqrt(-1)", {}).has_real_coefficients(nullptr));
  EXPECT_FALSE(Formula::compile("h*log(-2)", {}).has_real_coefficients(nullptr));
  EXPECT_FALSE(Formula::compile("(-4)^0.5*h", {}).has_real_coefficients(nullptr));
  EXPECT_TRUE(
      Formula::compile("h*log(2) + sqrt(4) + exp(-1) + 2^0.5", {}).has_real_coefficients(nullptr));
  EXPECT_TRUE(Formula::compile("sqrt(h) + log(h - 3)", {}).has_real_coefficients(nullptr));
}

TEST(Formula, RealCoefficientFormulasWithFunctionsCommuteWithRotations) {
  // f(u h u^-1) = u f(h) u^-1 for unit u, off the real axis (where the axis i is taken).
  const Quat real_c(0.7), complex_c(0.7, 0, 0.1, 0);
  std::mt19937 rng(1515);
  std::uniform_real_distribution<double> uniform(-2, 2);
  auto random = [&] { return Quat(uniform(rng), uniform(rng), uniform(rng), uniform(rng)); };
  for (const std::string text :
       {"c*sin(h)", "exp(h)+c", "c*cos(h) + tan(h)", "log(h)*c", "sqrt(h) - c", "h^1.5 + c*h^-0.5",
        "sinh(h)/cosh(h) + tanh(c*h)", "c*exp(h)*h^2"}) {
    SCOPED_TRACE(text);
    const Formula f = Formula::compile(text, {"c"});
    EXPECT_TRUE(f.has_real_coefficients(&real_c));
    EXPECT_FALSE(f.has_real_coefficients(&complex_c));
    int checked = 0, broken = 0;
    while (checked < 200) {
      const Quat h = random();
      if (abs(Quat(0, h.x, h.y, h.z)) < 0.2) continue;
      const Quat r = random();
      const Quat u = (1 / abs(r)) * r;
      const Quat rotated = u * h * inv(u);
      expect_near(f.eval(rotated, &real_c), u * f.eval(h, &real_c) * inv(u), 1e-13);
      // With a complex c the two sides differ (the check above could fail).
      const Quat lhs = f.eval(rotated, &complex_c), rhs = u * f.eval(h, &complex_c) * inv(u);
      broken += abs(lhs - rhs) > 1e-6 * (1 + abs(rhs));
      ++checked;
    }
    EXPECT_GT(broken, 150);
  }
}

TEST(Formula, ReportsTheColumnAndWhatWasExpected) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "formula 1:1: expected an expression"},
      {"h^", "formula 1:3: expected a literal real exponent after '^', such as 2, -1.5 or 0.5"},
      {"h^i", "formula 1:3: expected a literal real exponent after '^', such as 2, -1.5 or 0.5"},
      {"h^2i", "formula 1:3: expected a literal real exponent after '^', such as 2, -1.5 or 0.5"},
      {"h^(1.5)",
       "formula 1:3: expected a literal real exponent after '^', such as 2, -1.5 or 0.5"},
      {"h^x", "formula 1:3: expected a literal real exponent after '^', such as 2, -1.5 or 0.5"},
      {"h^-c", "formula 1:4: expected a literal real exponent after '^', such as 2, -1.5 or 0.5"},
      {"h^65", "formula 1:3: expected an exponent between -64 and 64"},
      {"h^-65", "formula 1:4: expected an exponent between -64 and 64"},
      {"h^64.5", "formula 1:3: expected an exponent between -64 and 64"},
      {"h^-64.01", "formula 1:4: expected an exponent between -64 and 64"},
      {"h^99999999999999999999", "formula 1:3: expected an exponent between -64 and 64"},
      {"h^2^3", "formula 1:4: expected an operator (use parentheses to chain powers)"},
      {"h^0.5^2", "formula 1:6: expected an operator (use parentheses to chain powers)"},
      {"sin h", "formula 1:5: expected '(' after 'sin'"},
      {"exp(h", "formula 1:6: expected ')'"},
      {"sinus(h)", "formula 1:1: unknown name 'sinus' (known: h, c, p)"},
      {"(h+1", "formula 1:5: expected ')'"},
      {"conj(h", "formula 1:7: expected ')'"},
      {"h+*2", "formula 1:3: expected an operand"},
      {"h+", "formula 1:3: expected an operand"},
      {"+h", "formula 1:1: expected an operand"},
      {"()", "formula 1:2: expected an operand"},
      {"2h", "formula 1:2: expected an operator"},
      {"3 i", "formula 1:3: expected an operator"},
      {"h (c)", "formula 1:3: expected an operator"},
      {"h)", "formula 1:2: expected an operator"},
      {"h # 2", "formula 1:3: expected an operator"},
      {"h + $", "formula 1:5: expected an operand"},
      {"conj h", "formula 1:6: expected '(' after 'conj'"},
      {"h + sqr", "formula 1:8: expected '(' after 'sqr'"},
      {"[1,2,3]", "formula 1:7: expected ','"},
      {"[1,2,3,4", "formula 1:9: expected ']'"},
      {"[1,2i,3,4]", "formula 1:4: expected a real number"},
      {"[1,h,3,4]", "formula 1:4: expected a real number"},
      {"1e999", "formula 1:1: expected a finite number"},
      {"h +\n  * 2", "formula 2:3: expected an operand"},
  };
  for (const auto& [text, message] : cases) {
    EXPECT_EQ(compile_error(text), message) << "formula: " << text;
  }
}

TEST(Formula, NamesUnknownIdentifiersAndTheKnownOnes) {
  EXPECT_EQ(compile_error("h+c*x"), "formula 1:5: unknown name 'x' (known: h, c, p)");
  EXPECT_EQ(compile_error("e*h", {}), "formula 1:1: unknown name 'e' (known: h)");
  EXPECT_EQ(compile_error("H^2", {}), "formula 1:1: unknown name 'H' (known: h)");
  EXPECT_EQ(compile_error("h^2 + c1", {"c1", "a_2"}), "");
  EXPECT_EQ(compile_error("h^2 + a_2", {"c1", "a_2"}), "");
}

TEST(Formula, RejectsReservedOrMalformedConstantNames) {
  for (const std::string name :
       {"h",   "i",   "j",   "k",   "conj", "inv", "norm", "abs", "sqr",  "",     "2a",
        "a b", "c-d", "exp", "log", "sqrt", "sin", "cos",  "tan", "sinh", "cosh", "tanh"}) {
    EXPECT_THROW(Formula::compile("h", {name}), InvalidInput) << "name '" << name << "'";
  }
  EXPECT_THROW(Formula::compile("h", {"c", "c"}), InvalidInput);
}

TEST(Formula, RejectsAbsurdlyLargeFormulas) {
  EXPECT_THROW(Formula::compile(std::string(100, '(') + "h" + std::string(100, ')'), {}),
               InvalidInput);
  EXPECT_THROW(Formula::compile(std::string(100, '-') + "h", {}), InvalidInput);
  EXPECT_NO_THROW(Formula::compile(std::string(60, '(') + "h" + std::string(60, ')'), {}));
  std::string sum = "h";
  while (sum.size() < 5000) sum += "+h";
  EXPECT_THROW(Formula::compile(sum, {}), InvalidInput);
  // A long but legal sum evaluates in a bounded register file.
  std::string ok = "h";
  for (int n = 1; n < 1000; ++n) ok += "+h";
  expect_near(Formula::compile(ok, {}).eval(kH, nullptr), 1000.0 * kH, 1e-12);
}

TEST(Formula, BalancedTreesFitTheRegisterFile) {
  // A perfectly balanced product of 256 factors needs the most registers per character.
  std::string t = "h";
  for (int level = 0; level < 8; ++level) t = "(" + t + ")*(" + t + ")";
  ASSERT_LE(t.size(), 4096u);
  const Formula f = Formula::compile(t, {});
  expect_near(f.eval(Quat(1.001, 0, 0, 0), nullptr), Quat(std::pow(1.001, 256)), 1e-12);
}

TEST(Formula, RefusesMoreConstantsThanTheRegisterFileHolds) {
  std::vector<std::string> names;
  std::vector<Quat> values;
  std::string sum = "h";
  for (int n = 0; n < 40; ++n) {
    names.push_back("a" + std::to_string(n));
    values.push_back(Quat(n));
    sum += "+a" + std::to_string(n);
  }
  EXPECT_NE(compile_error(sum, names).find("expected a smaller formula"), std::string::npos);
  // Thirty constants fit, and unused ones take no register.
  std::string thirty = "h";
  for (int n = 0; n < 30; ++n) thirty += "+a" + std::to_string(n);
  const Formula f = Formula::compile(thirty, names);
  expect_near(f.eval(Quat(1), values.data()), Quat(1 + 29 * 30 / 2), 0);
}

TEST(Formula, NewtonMapOfTheCubeFixesTheCubeRootsOfUnity) {
  const Formula f = Formula::compile("(2*h^3+1)/(3*h^2)", {});
  const double s = std::sqrt(3.0) / 2;
  for (const Quat& root : {Quat(1), Quat(-0.5, s, 0, 0), Quat(-0.5, -s, 0, 0), Quat(-0.5, 0, s, 0),
                           Quat(-0.5, 0, 0.6 * s, 0.8 * s)}) {
    expect_near(repeated_product(root, 3), Quat(1), 1e-15);
    expect_near(f.eval(root, nullptr), root, 1e-15);
  }
  // Away from the roots it is Newton's step h - (h^3 - 1)/(3 h^2).
  expect_near(f.eval(kH, nullptr),
              kH - (repeated_product(kH, 3) - Quat(1)) * inv(3.0 * repeated_product(kH, 2)));
}

TEST(Formula, APoleGivesNonFiniteValuesWithoutThrowing) {
  const Formula f = Formula::compile("(2*h^3+1)/(3*h^2)", {});
  EXPECT_FALSE(is_finite(f.eval(Quat(), nullptr)));
  const Formula g = Formula::compile("h/c + 1/h", {"c"});
  const Quat zero;
  EXPECT_FALSE(is_finite(g.eval(kH, &zero)));
  EXPECT_FALSE(is_finite(Formula::compile("inv(h)", {}).eval(Quat(), nullptr)));
  EXPECT_FALSE(is_finite(Formula::compile("h/0", {}).eval(kH, nullptr)));
  EXPECT_FALSE(is_finite(Formula::compile("log(h)", {}).eval(Quat(), nullptr)));
  EXPECT_FALSE(is_finite(Formula::compile("h^-1.5", {}).eval(Quat(), nullptr)));
  EXPECT_FALSE(is_finite(Formula::compile("1/sin(h)", {}).eval(Quat(), nullptr)));
  EXPECT_FALSE(is_finite(Formula::compile("exp(h)", {}).eval(Quat(800, 1, 0, 0), nullptr)));
  EXPECT_FALSE(is_finite(Formula::compile("c*sin(h)", {"c"}).eval(Quat(0, 0, 800, 0), &kP)));
}

TEST(Formula, ReportsTheConstantsItUses) {
  const Formula f = Formula::compile("p*h^2 + q", {"c", "p", "q"});
  EXPECT_EQ(f.constants_used(), (std::vector<bool>{false, true, true}));
  EXPECT_EQ(f.constant_names(), (std::vector<std::string>{"c", "p", "q"}));
  EXPECT_EQ(f.text(), "p*h^2 + q");
  const Quat constants[] = {Quat(100, 100, 100, 100), kP, kQ};
  expect_near(f.eval(kH, constants), kP * sqr(kH) + kQ);
}

TEST(Formula, KnowsWhenItsCoefficientsAreReal) {
  const Formula f = Formula::compile("p*h^2 + q - conj(h)/abs(h) + [2,0,0,0]", {"c", "p", "q"});
  const Quat real[] = {Quat(0, 1, 1, 1), Quat(2), Quat(-0.5)};  // c is unused
  const Quat complex_p[] = {Quat(), Quat(2, 0, 0.1, 0), Quat(-0.5)};
  EXPECT_TRUE(f.has_real_coefficients(real));
  EXPECT_FALSE(f.has_real_coefficients(complex_p));
  EXPECT_FALSE(Formula::compile("h^2 + 0.5i", {}).has_real_coefficients(nullptr));
  EXPECT_FALSE(Formula::compile("h^2 + [0,0,0,1]", {}).has_real_coefficients(nullptr));
  EXPECT_TRUE(Formula::compile("(2*h^3+1)/(3*h^2)", {}).has_real_coefficients(nullptr));

  // The fact it promises: f(u h u^-1) = u f(h) u^-1 for every unit quaternion u.
  const Quat u = (1 / abs(Quat(0.3, 0.5, -0.2, 0.7))) * Quat(0.3, 0.5, -0.2, 0.7);
  const Quat rotated = u * kH * inv(u);
  EXPECT_NEAR(rotated.w, kH.w, 1e-15);
  expect_near(f.eval(rotated, real), u * f.eval(kH, real) * inv(u));
}

TEST(Formula, CopiesShareTheProgramAndEvaluateConcurrently) {
  const Formula f = Formula::compile("p*(2*h^3+1)/(3*h^2) + q", {"p", "q"});
  const Formula copy = f;
  EXPECT_EQ(&copy.text(), &f.text());  // same program, not a recompilation
  const Quat constants[] = {kP, kQ};
  auto run = [&](const Formula& formula, std::vector<Quat>* out) {
    for (int n = 0; n < 20000; ++n) {
      const double t = n * 1e-4;
      out->push_back(formula.eval(Quat(t, 1 - t, 0.5 * t, -t), constants));
    }
  };
  std::vector<Quat> a, b, expected;
  std::thread ta(run, std::cref(f), &a);
  std::thread tb(run, std::cref(copy), &b);
  ta.join();
  tb.join();
  run(f, &expected);
  ASSERT_EQ(a.size(), expected.size());
  ASSERT_EQ(b.size(), expected.size());
  for (std::size_t n = 0; n < expected.size(); ++n) {
    ASSERT_EQ(distance(a[n], expected[n]), 0) << n;
    ASSERT_EQ(distance(b[n], expected[n]), 0) << n;
  }
}

TEST(Formula, DefaultConstructedFormulaIsTheIdentity) {
  const Formula f;
  expect_near(f.eval(kH, nullptr), kH, 0);
  EXPECT_EQ(f.text(), "h");
  EXPECT_TRUE(f.constant_names().empty());
}

/// Random formulas, written out with parentheses, together with their value computed directly
/// with the quaternion.h operators: a reference interpreter for the compiled program.
class RandomFormula {
 public:
  /// @param[in] analytic  also draw the analytic functions and real powers
  explicit RandomFormula(unsigned seed, bool analytic = false) : rng_(seed), analytic_(analytic) {}

  /// Text and value of a random expression of the given depth; `scale` grows to the largest
  /// magnitude met on the way, the yardstick of rounding errors.
  std::pair<std::string, Quat> make(int depth) {
    const int choice = depth <= 0 ? pick(4) : pick(analytic_ ? 14 : 12);
    switch (choice) {
      case 0:
        return note({"h", kH});
      case 1:
        return pick(2) ? note({"p", kP}) : note({"q", kQ});
      case 2: {
        const std::pair<std::string, double> reals[] = {
            {"2", 2}, {"0.5", 0.5}, {"3", 3}, {"1.25", 1.25}, {".75", 0.75}};
        const auto& r = reals[pick(5)];
        return note({r.first, Quat(r.second)});
      }
      case 3: {
        const std::pair<std::string, Quat> units[] = {{"0.5i", Quat(0, 0.5, 0, 0)},
                                                      {"j", Quat(0, 0, 1, 0)},
                                                      {"[1,-0.5,0.25,2]", Quat(1, -0.5, 0.25, 2)}};
        return note(units[pick(3)]);
      }
      case 4:
      case 5:
      case 6:
      case 7:
      case 11: {
        const auto a = make(depth - 1);
        const auto b = make(depth - 1);
        const std::string text_a = "(" + a.first + ")";
        const std::string text_b = "(" + b.first + ")";
        if (choice == 4) return note({text_a + "+" + text_b, a.second + b.second});
        if (choice == 5) return note({text_a + "-" + text_b, a.second - b.second});
        if (choice == 7) return note({text_a + "/" + text_b, a.second * inv(b.second)});
        return note({text_a + "*" + text_b, a.second * b.second});
      }
      case 8: {
        const auto a = make(depth - 1);
        return note({"-(" + a.first + ")", -a.second});
      }
      case 9: {
        const auto a = make(depth - 1);
        const int n = pick(8) - 3;
        return note({"(" + a.first + ")^" + std::to_string(n), repeated_product(a.second, n)});
      }
      case 12: {
        const auto a = make(depth - 1);
        const std::pair<const char*, Quat (*)(const Quat&)> functions[] = {
            {"exp", detail::qexp},   {"log", detail::qlog},   {"sqrt", detail::qsqrt},
            {"sin", detail::qsin},   {"cos", detail::qcos},   {"tan", detail::qtan},
            {"sinh", detail::qsinh}, {"cosh", detail::qcosh}, {"tanh", detail::qtanh}};
        const auto& f = functions[pick(9)];
        return note({std::string(f.first) + "(" + a.first + ")", f.second(a.second)});
      }
      case 13: {
        const auto a = make(depth - 1);
        const std::pair<const char*, double> exponents[] = {
            {"0.5", 0.5}, {"-1.5", -1.5}, {"2.5", 2.5}, {".25", 0.25}, {"-0.5", -0.5}};
        const auto& x = exponents[pick(5)];
        return note({"(" + a.first + ")^" + x.first, detail::qpow(a.second, x.second)});
      }
      default: {
        const auto a = make(depth - 1);
        switch (pick(5)) {
          case 0:
            return note({"conj(" + a.first + ")", conj(a.second)});
          case 1:
            return note({"inv(" + a.first + ")", inv(a.second)});
          case 2:
            return note({"norm(" + a.first + ")", Quat(norm2(a.second))});
          case 3:
            return note({"abs(" + a.first + ")", Quat(abs(a.second))});
          default:
            return note({"sqr(" + a.first + ")", sqr(a.second)});
        }
      }
    }
  }

  double scale = 1;

 private:
  int pick(int n) { return static_cast<int>(rng_() % static_cast<unsigned>(n)); }
  std::pair<std::string, Quat> note(std::pair<std::string, Quat> e) {
    if (is_finite(e.second)) scale = std::max(scale, abs(e.second));
    return e;
  }
  std::mt19937 rng_;
  bool analytic_;
};

/// Compiles and evaluates 3000 random formulas against their direct values; counts the finite
/// ones of moderate size that were compared.
void compare_random_formulas(bool analytic, int* compared) {
  const Quat constants[] = {kP, kQ};
  for (unsigned seed = 0; seed < 3000; ++seed) {
    RandomFormula random(seed, analytic);
    const auto [text, expected] = random.make(1 + static_cast<int>(seed % 6));
    if (!is_finite(expected) || random.scale > 1e8) continue;
    const Formula f = Formula::compile(text, {"p", "q"});
    const Quat actual = f.eval(kH, constants);
    ASSERT_LE(distance(actual, expected), 1e-11 * random.scale) << text;
    ++*compared;
  }
}

TEST(Formula, RandomFormulasAgreeWithDirectQuaternionArithmetic) {
  int compared = 0;
  compare_random_formulas(false, &compared);
  EXPECT_GT(compared, 2000);
}

TEST(Formula, RandomFormulasWithAnalyticFunctionsAgreeWithDirectEvaluation) {
  // The same random expressions with exp, log, ..., tanh and real powers mixed in, against a
  // direct evaluation with the functions of quat_functions.h.
  int compared = 0;
  compare_random_formulas(true, &compared);
  EXPECT_GT(compared, 1500);
}

TEST(Formula, RandomAndMutatedTextEitherCompilesOrThrowsInvalidInput) {
  // A cheap stand-in for the libFuzzer target (tests/fuzz/formula_fuzz.cpp) that runs everywhere.
  const std::vector<std::string> pieces = {
      "h",    "c",     "p",    "x",    "i", "3i", "0.5", "1e-3",  ".5",   "2", "64", "65",
      "+",    "-",     "*",    "/",    "^", "^-", "(",   ")",     "[",    "]", ",",  "conj(",
      "inv(", "norm(", "abs(", "sqr(", " ", "\n", "#",   "1e999", "\xff", "e", "."};
  const std::vector<std::string> seeds = {"(2*h^3+1)/(3*h^2)", "p*h^2 + q", "[1,2,3,4]*h/c",
                                          "conj(h)^-3 - abs(c)*2i"};
  std::mt19937 rng(12345);
  const Quat constants[] = {kP, kQ};
  int compiled = 0;
  for (int n = 0; n < 4000; ++n) {
    std::string text;
    if (n % 2 == 0) {
      const int count = 1 + static_cast<int>(rng() % 12);
      for (int m = 0; m < count; ++m) text += pieces[rng() % pieces.size()];
    } else {
      text = seeds[rng() % seeds.size()];
      for (int m = 0; m < 3; ++m) {
        const std::size_t at = rng() % (text.size() + 1);
        switch (rng() % 3) {
          case 0:
            text.insert(at, pieces[rng() % pieces.size()]);
            break;
          case 1:
            if (at < text.size()) text.erase(at, 1);
            break;
          default:
            if (at < text.size()) text[at] = static_cast<char>(rng() % 256);
            break;
        }
      }
    }
    try {
      const Formula f = Formula::compile(text, {"c", "p"});
      f.eval(kH, constants);
      ++compiled;
    } catch (const InvalidInput&) {
    }
  }
  EXPECT_GT(compiled, 40);  // the generator reaches valid formulas too
}

}  // namespace
}  // namespace qjulia
