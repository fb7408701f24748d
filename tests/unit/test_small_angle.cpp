// sincos_small_angle (src/core/small_angle.hpp): the Taylor series used for the per-step
// rotation angles of clumps must give the library's sine and cosine to a few units in the last
// place over its range, and hand larger angles to the library.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "core/small_angle.hpp"

using biodem::kSmallAngleMax;
using biodem::sincos_small_angle;

TEST(SmallAngle, MatchesLibraryWithinFourUlpOverItsRange) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-kSmallAngleMax, kSmallAngleMax);
  const double eps = std::numeric_limits<double>::epsilon();
  double worst_s = 0.0, worst_c = 0.0;
  for (int n = 0; n < 200000; ++n) {
    // Uniform in the range and spread over decades down to 1e-12 rad.
    const double x = n % 2 ? u(rng) : u(rng) * std::pow(10.0, -static_cast<double>(n % 11));
    double s, c;
    sincos_small_angle(x, s, c);
    if (x != 0.0) worst_s = std::max(worst_s, std::abs(s - std::sin(x)) / std::abs(std::sin(x)));
    worst_c = std::max(worst_c, std::abs(c - std::cos(x)) / std::cos(x));
  }
  EXPECT_LE(worst_s, 4.0 * eps);
  EXPECT_LE(worst_c, 4.0 * eps);
  double s, c;
  sincos_small_angle(0.0, s, c);
  EXPECT_EQ(s, 0.0);
  EXPECT_EQ(c, 1.0);
  sincos_small_angle(0.05, s, c);  // sin 0.05 = 0.04997916927067833, cos 0.05 = 0.9987502603949663
  EXPECT_NEAR(s, 0.04997916927067833, 1e-17);
  EXPECT_NEAR(c, 0.9987502603949663, 1e-16);
  sincos_small_angle(-0.05, s, c);  // odd and even
  EXPECT_NEAR(s, -0.04997916927067833, 1e-17);
  EXPECT_NEAR(c, 0.9987502603949663, 1e-16);
}

TEST(SmallAngle, LargerAnglesAndNanGoToTheLibrary) {
  for (double x : {0.07, -0.3, 1.0, 3.0, -100.0}) {
    double s, c;
    sincos_small_angle(x, s, c);
    EXPECT_EQ(s, std::sin(x)) << x;
    EXPECT_EQ(c, std::cos(x)) << x;
  }
  double s, c;
  sincos_small_angle(std::numeric_limits<double>::quiet_NaN(), s, c);
  EXPECT_TRUE(std::isnan(s) && std::isnan(c));
}
