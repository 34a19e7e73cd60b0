#include "core/math.h"

#include <gtest/gtest.h>

#include <Eigen/Core>

namespace mr {
namespace {

TEST(Math, SafeFunctionsClampRoundingError) {
  EXPECT_EQ(SafeSqrt(-1e-9), 0.0);
  EXPECT_EQ(SafeACos(1.0 + 1e-12), 0.0);
  EXPECT_DOUBLE_EQ(SafeACos(-1.0 - 1e-12), kPi);
  EXPECT_DOUBLE_EQ(SafeASin(1.0 + 1e-12), kPi / 2);
  EXPECT_FALSE(std::isnan(SafeACos(1.0f + 1e-7f)));
}

TEST(Math, DifferenceOfProductsAvoidsCancellation) {
  // a = 1 + 2^-30, b = 1 - 2^-30: a*b = 1 - 2^-60 exactly, which a double
  // product rounds to 1, so the naive a*b - 1*1 returns 0.
  const double a = 1.0 + 0x1p-30, b = 1.0 - 0x1p-30;
  volatile double ab = a * b;
  EXPECT_EQ(ab - 1.0, 0.0);
  EXPECT_EQ(DifferenceOfProducts(a, b, 1.0, 1.0), -0x1p-60);
  const float fa = 4097.0f, fb = 4095.0f;  // fa*fb = 4097*4095 = 16777215 exactly representable
  EXPECT_EQ(DifferenceOfProducts(fa, fb, 4096.0f, 4096.0f), -1.0f);
}

TEST(Math, CompensatedSumKeepsSmallTermsAfterAHugeOne) {
  // A sun (1e6) followed by a million sky pixels of 1e-6 (dynamic range 1e12):
  // a float running sum loses every one of them.
  CompensatedSum<float> s;
  float naive = 0;
  s += 1e6f;
  naive += 1e6f;
  for (int i = 0; i < 1000000; ++i) {
    s += 1e-6f;
    naive += 1e-6f;
  }
  EXPECT_EQ(naive, 1e6f);                      // the failure we guard against
  EXPECT_NEAR(s.Value(), 1e6f + 1.0f, 0.07f);  // float ulp at 1e6 is 0.0625
  CompensatedSum<double> d;
  d += 1e16;
  d += 1.0;
  d += -1e16;
  EXPECT_EQ(d.Value(), 1.0);  // naive double gives 0
}

TEST(Math, SolveQuadraticIsStable) {
  double t0, t1;
  // x^2 - 1e8 x + 1 = 0: roots 1e8 and 1e-8; the textbook formula loses the small one.
  ASSERT_TRUE(SolveQuadratic(1.0, -1e8, 1.0, &t0, &t1));
  EXPECT_NEAR(t0, 1e-8, 1e-8 * 1e-12);
  EXPECT_NEAR(t1, 1e8, 1e8 * 1e-12);
  EXPECT_FALSE(SolveQuadratic(1.0, 0.0, 1.0, &t0, &t1));
  ASSERT_TRUE(SolveQuadratic(0.0, 2.0, -4.0, &t0, &t1));  // linear
  EXPECT_EQ(t0, 2.0);
  ASSERT_TRUE(SolveQuadratic(1.0, 0.0, 0.0, &t0, &t1));
  EXPECT_EQ(t0, 0.0);
}

TEST(Math, AngleBetweenAccurateNearZeroAndPi) {
  Eigen::Vector3d a(1, 0, 0);
  for (double angle : {1e-10, 1e-4, kPi - 1e-4, kPi - 1e-10}) {
    Eigen::Vector3d b(std::cos(angle), std::sin(angle), 0);
    // acos(dot) would return 0 for 1e-10 (dot rounds to 1).
    EXPECT_NEAR(AngleBetween(a, b), angle, 1e-15 + angle * 1e-12) << angle;
  }
  EXPECT_EQ(AngleBetween(a, a), 0.0);
  EXPECT_NEAR(AngleBetween(a, Eigen::Vector3d(-a)), kPi, 1e-15);
}

}  // namespace
}  // namespace mr
