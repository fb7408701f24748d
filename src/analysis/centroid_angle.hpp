// Centroid angle alpha (SPEC 6): angle between the horizontal and the line from the drum centre
// to the powder's centre of mass, 90 deg for a flat bed at rest, increasing as the bed is lifted
// on the rising side (+x for a drum turning counter-clockwise seen from +z, y up):
//     alpha = 90 deg + atan2(x_c, -y_c)
#pragma once
#include <cmath>
#include <numbers>

namespace biodem::analysis {

inline double centroid_angle_deg(double x_c, double y_c) {
  return 90.0 + std::atan2(x_c, -y_c) * 180.0 / std::numbers::pi;
}

}  // namespace biodem::analysis
