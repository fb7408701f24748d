// Centroid angle alpha (SPEC 6), the formula itself: alpha = 90 deg + atan2(x_c, -y_c) for a drum
// turning counter-clockwise seen from +z, and its mirror image 90 deg - atan2(x_c, -y_c) for a
// clockwise drum, so that a bed lifted on the rising side has alpha above 90 deg either way.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "analysis/centroid_angle.hpp"

using biodem::analysis::centroid_angle_deg;

namespace {
// atan(1/2) in degrees: the centre of mass 1 cm to the side of and 2 cm below the drum's centre.
const double kTilt = std::atan(0.5) * 180.0 / std::numbers::pi;  // 26.565 deg
}  // namespace

TEST(CentroidAngle, FlatBedIsNinetyDegreesInBothDirections) {
  EXPECT_DOUBLE_EQ(centroid_angle_deg(0.0, -0.02), 90.0);
  EXPECT_DOUBLE_EQ(centroid_angle_deg(0.0, -0.02, true), 90.0);
}

TEST(CentroidAngle, BedLiftedOnTheRisingSideIsAboveNinetyForEitherDirection) {
  // Counter-clockwise: the bed rises at +x.
  EXPECT_NEAR(centroid_angle_deg(0.01, -0.02), 90.0 + kTilt, 1e-12);
  EXPECT_NEAR(centroid_angle_deg(-0.01, -0.02), 90.0 - kTilt, 1e-12);
  // Clockwise: the bed rises at -x; the mirror image of the same bed gives the same alpha.
  EXPECT_NEAR(centroid_angle_deg(-0.01, -0.02, true), 90.0 + kTilt, 1e-12);
  EXPECT_NEAR(centroid_angle_deg(0.01, -0.02, true), 90.0 - kTilt, 1e-12);
  // A bed carried up to the horizontal on the rising side: 180 deg.
  EXPECT_NEAR(centroid_angle_deg(0.02, 0.0), 180.0, 1e-12);
  EXPECT_NEAR(centroid_angle_deg(-0.02, 0.0, true), 180.0, 1e-12);
}
