// Centroid angle alpha (SPEC 6): angle between the horizontal and the line from the drum centre
// to the powder's centre of mass, 90 deg for a flat bed at rest, increasing as the bed is lifted
// on the rising side (+x for a drum turning counter-clockwise seen from +z, y up):
//     alpha = 90 deg + atan2(x_c, -y_c)
// For a drum turning clockwise seen from +z (rpm < 0) the bed rises at -x and the mirror image
// holds, alpha = 90 deg - atan2(x_c, -y_c), so that lifting the bed on the rising side increases
// alpha for either direction.
#pragma once
#include <cmath>
#include <numbers>

namespace biodem::analysis {

inline double centroid_angle_deg(double x_c, double y_c, bool clockwise = false) {
  const double a = std::atan2(x_c, -y_c) * 180.0 / std::numbers::pi;
  return clockwise ? 90.0 - a : 90.0 + a;
}

}  // namespace biodem::analysis
