#include "qjulia/field/quaternion.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace qjulia
