// The drum seen from its end, coloured by speed (SPEC 6: "snapshots coloured by speed"): every
// sphere of the whole width seen from +z as in the back-lit frames, each a disc in the colour of
// its speed, the nearest (largest z) drawn last, with a colour bar, written by `run` at each
// snapshot (`speed_images/speed_NNNNNN.png`, [output] speed_images). Drawn with OpenCV: not in
// the lean build.
#pragma once
#include <array>
#include <cstdint>
#include <span>
#include <string>

#include <opencv2/core.hpp>

namespace biodem::output {

/// The colour of a speed that is `fraction` of the scale's top (0: slowest, 1: the top), as
/// blue, green, red: the viridis map (dark violet, blue, teal, green, yellow) interpolated
/// linearly between its values at 0, 1/4, 1/2, 3/4 and 1. Below 0 gives the colour of 0, above 1
/// the colour of 1 (speeds above the scale are drawn at its top); NaN gives mid grey.
std::array<std::uint8_t, 3> speed_colour_bgr(double fraction);

struct SpeedImageOptions {
  int drum_px = 512;            // side of the square holding the drum ([output] speed_image_size_px)
  double max_speed_m_s = 0.01;  // top of the colour scale (> 0)
  double period_z_m = 0.0;      // > 0: z is periodic with this period from z = 0 (a periodic drum's
                                // width): depth order by z - period floor(z / period)
  std::string title;            // one line above the drum (ASCII); ", N faster than the scale" is added
};

/// Where a point of the cross-section lands in the image (pixel centres at integer
/// coordinates): column = centre_col + x px_per_m, row = centre_row - y px_per_m.
struct SpeedImageGeometry {
  double centre_col = 0.0, centre_row = 0.0, px_per_m = 0.0, disc_px = 0.0;
  int width = 0, height = 0;
  int bar_col0 = 0, bar_col1 = 0, bar_row_top = 0, bar_row_bottom = 0;  // the colour bar's pixels
};
SpeedImageGeometry speed_image_geometry(double drum_radius_m, const SpeedImageOptions& opt);

/// The image (8-bit BGR): the drum's inside light, its rim dark, the spheres (centre x, y, z in
/// m, the drum's axis through x = y = 0; radius; speed in m/s) drawn in increasing z (wrapped
/// into one period when period_z_m > 0), the colour bar on the right with its ticks in m/s and a
/// triangle on top in the top colour (speeds above the scale). Spheres with a non-finite centre,
/// radius or speed are not drawn. Throws std::invalid_argument for spans of unequal length, a
/// drum radius or scale top <= 0, or drum_px < 64.
cv::Mat render_speed_image(std::span<const double> x_m, std::span<const double> y_m, std::span<const double> z_m,
                           std::span<const double> r_m, std::span<const double> speed_m_s, double drum_radius_m,
                           const SpeedImageOptions& opt);

}  // namespace biodem::output
