// The default top of the speed images' colour scale (output/speed_image.hpp), without OpenCV so
// that the case report can state it in every build.
#pragma once
#include <cmath>
#include <numbers>

namespace biodem::output {

/// Twice the rim speed of a drum of radius R turning at rpm (2 |rpm| 2 pi / 60 R): a bed turning
/// with the drum spans the lower half of the colours, and what flows faster than the rim stands
/// out in the upper half and at the top. 0.1 m/s for a drum at rest.
inline double default_speed_scale_m_s(double drum_radius_m, double rpm) {
  const double rim = std::abs(rpm) * 2.0 * std::numbers::pi / 60.0 * drum_radius_m;
  return rim > 0.0 ? 2.0 * rim : 0.1;
}

}  // namespace biodem::output
