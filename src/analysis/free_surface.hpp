// Free-surface irregularity r^2 and surface angle (SPEC 6).
//
// The free surface is the upper boundary of the bed between its two contacts with the drum
// mantle. It is sampled as a profile of (x, y) points, one per vertical bin, and a straight line
// y = a + b x is fitted by ordinary least squares (y on x). Then
//     r^2       = 1 - SS_res / SS_tot      (coefficient of determination of that fit)
//     angle_deg = atan(b) in degrees        (> 0 when the surface rises towards +x)
// r^2 is 1 for a flat (straight) surface and lower for a rough, curved or stepped one. A profile
// whose heights are all equal (SS_tot = 0) is a perfect straight line: r^2 = 1.
//
// Coordinates are in the drum cross-section, relative to the drum centre, y up; for a drum
// turning counter-clockwise seen from +z the bed rises at +x.
//
// Profile rule for particles (documented in docs/analysis.md):
//   * bins of width `bin_width_m` span [-R, R] in x; a particle belongs to the bin of its centre;
//   * in each bin the column is climbed from its lowest particle, which must rest on the mantle
//     (gap to the mantle at most `max_gap_m`), through every particle whose bottom (y - r) is
//     within `max_gap_m` of the highest top (y + r) reached so far; the bin's surface point is
//     that highest top (x of its particle). Grains in flight and clusters thrown or stuck to the
//     mantle above the bed are separated from the bed by a larger gap and are not surface;
//   * a surface point within `wall_zone_m` of the mantle (distance from the centre greater than
//     R - wall_zone_m) is excluded: that removes the meniscus against the wall at the bed's two
//     contacts and the columns beyond them;
//   * the profile is the longest run of consecutive bins that kept a point, i.e. the surface
//     between the bed's two contacts with the mantle.
//
// Image rule (binary mask, 255 = powder): the mask is reduced to its largest 8-connected
// component (the bed; detached particles in flight are dropped); per image column the bed is
// climbed from its lowest pixel through gaps of at most `max_gap_px`; per bin of `bin_px`
// columns the highest top is the surface point; points within `wall_zone_px` of the disc rim
// are excluded; the longest run of consecutive bins is fitted as above, in pixel units with
// y pointing up. `mirror_x` flips x (a drum seen turning clockwise, SPEC 11 `--rotation cw`).
#pragma once
#include <cstddef>
#include <span>
#include <vector>

#include <opencv2/core.hpp>

namespace biodem::analysis {

struct SurfaceFit {
  double r2;          // NaN when fewer than 3 bins
  double angle_deg;   // NaN when fewer than 3 bins
  std::size_t bins_used;
  bool valid;         // bins_used >= 3
};

struct SurfaceParams {
  double bin_width_m;  // width of the vertical bins
  double wall_zone_m;  // surface points closer than this to the mantle are excluded
  double max_gap_m;    // a particle more than this above the bed below it is not connected

  /// Defaults from the (largest) particle diameter d: bins of 2 d, wall zone 2 d, gap d.
  static SurfaceParams for_particle_diameter(double d_m);
};

struct ProfilePoint {
  double x;
  double y;
};

/// Surface profile of a bed of circles (x, y, radius; drum-centred, y up), one point per bin,
/// ordered by x. Throws std::invalid_argument if the spans differ in length or a parameter is
/// not positive.
std::vector<ProfilePoint> free_surface_profile(std::span<const double> x_m,
                                               std::span<const double> y_m,
                                               std::span<const double> radius_m,
                                               double drum_radius_m, const SurfaceParams& params);

/// Profile extraction followed by the straight-line fit.
SurfaceFit fit_free_surface(std::span<const double> x_m, std::span<const double> y_m,
                            std::span<const double> radius_m, double drum_radius_m,
                            const SurfaceParams& params);

/// Least-squares line y on x through the points; r^2 and angle as above.
SurfaceFit fit_surface_line(std::span<const ProfilePoint> profile);

struct ImageSurfaceParams {
  int bin_px = 1;             // columns per bin
  double wall_zone_px = -1.0; // < 0: 5 % of the disc radius
  double max_gap_px = -1.0;   // < 0: 5 % of the disc radius, at least 2 px
  bool mirror_x = false;      // drum seen turning clockwise
};

/// Surface profile of a binary powder mask (CV_8U, non-zero = powder) inside a disc of centre
/// (cx_px, cy_px) (pixel-centre coordinates: pixel (row i, column j) is at x = j, y = i) and
/// radius radius_px. Returned points are centred on the disc, y up, in pixels.
std::vector<ProfilePoint> free_surface_profile_mask(const cv::Mat& mask, double cx_px,
                                                    double cy_px, double radius_px,
                                                    const ImageSurfaceParams& params);

SurfaceFit fit_free_surface_mask(const cv::Mat& mask, double cx_px, double cy_px,
                                 double radius_px, const ImageSurfaceParams& params);

}  // namespace biodem::analysis
