// Back-lit frames rendered from a simulation (SPEC 6 video path, SPEC 11 `frames/*.png`): what
// the camera on the drum axis would see, so the video analysis can be checked on simulations.
#pragma once
#include <span>

#include <opencv2/core.hpp>

#include "analysis/backlit_image.hpp"

namespace biodem::analysis {

struct BacklitStyle {
  double disc_fraction = 0.92;  // disc diameter / image size
  int background = 40;          // grey outside the drum
  int disc = 230;               // back-light seen through the empty drum
  int particle = 20;            // powder shadow
};

/// Square CV_8UC1 image of size_px: dark background, bright disc of the drum (centred), and each
/// particle a dark filled circle (x, y, radius in metres, drum-centred, y up, as seen along the
/// drum axis from +z, so a counter-clockwise drum raises the bed on the right of the image).
/// Circles are anti-aliased and at least one pixel wide. Throws std::invalid_argument on spans of
/// different length or non-positive sizes.
cv::Mat render_backlit_frame(std::span<const double> x_m, std::span<const double> y_m,
                             std::span<const double> r_m, double drum_radius_m, int size_px,
                             const BacklitStyle& style);

cv::Mat render_backlit_frame(std::span<const double> x_m, std::span<const double> y_m,
                             std::span<const double> r_m, double drum_radius_m, int size_px);

/// The drum disc as drawn by render_backlit_frame (centre (size - 1) / 2, radius
/// disc_fraction * size / 2), for measuring rendered frames without searching for it.
DrumDisc rendered_disc(int size_px, const BacklitStyle& style);

}  // namespace biodem::analysis
