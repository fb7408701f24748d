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
// One method for simulations and images (issue 12): the free surface is always taken from a
// binary image of the bed's cross-section, the shadow the camera sees. A simulation's particles
// are first drawn as a back-lit frame with the renderer of `frames/*.png`
// (render_backlit_frame, SurfaceParams::raster_px wide) and that frame goes through the video
// path (measure_backlit_frame with the known disc), so r^2 from a run and r^2 from `biodem video`
// on the run's own frames differ only by the disc the video finds (sub-pixel).
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

struct ProfilePoint {
  double x;
  double y;
};

/// Least-squares line y on x through the points; r^2 and angle as above.
SurfaceFit fit_surface_line(std::span<const ProfilePoint> profile);

struct ImageSurfaceParams {
  int bin_px = 1;             // columns per bin
  double wall_zone_px = -1.0; // < 0: 5 % of the disc radius
  double max_gap_px = -1.0;   // < 0: 5 % of the disc radius, at least 2 px
  bool mirror_x = false;      // drum seen turning clockwise
};

/// The free surface of a simulation's particles: rendered as a back-lit frame of raster_px x
/// raster_px pixels (the drum disc 0.92 of it, as `frames/*.png`) and measured as a video frame.
struct SurfaceParams {
  int raster_px = 512;         // as [output] frame_size_px (default 512)
  ImageSurfaceParams image{};  // bin width, wall zone, gap in pixels of that raster

  /// The raster of the run's frames, so that its r^2 and the frames' agree.
  static SurfaceParams for_frames(int frame_size_px);
};

/// Surface profile of a binary powder mask (CV_8U, non-zero = powder) inside a disc of centre
/// (cx_px, cy_px) (pixel-centre coordinates: pixel (row i, column j) is at x = j, y = i) and
/// radius radius_px. Returned points are centred on the disc, y up, in pixels.
std::vector<ProfilePoint> free_surface_profile_mask(const cv::Mat& mask, double cx_px,
                                                    double cy_px, double radius_px,
                                                    const ImageSurfaceParams& params);

SurfaceFit fit_free_surface_mask(const cv::Mat& mask, double cx_px, double cy_px,
                                 double radius_px, const ImageSurfaceParams& params);

/// Free surface of a bed of circles (x, y, radius in metres; drum-centred, y up, seen from +z)
/// by the image method above; the fit's x and y are in pixels of the raster. Throws
/// std::invalid_argument if the spans differ in length or the drum radius or raster is not > 0.
SurfaceFit fit_free_surface(std::span<const double> x_m, std::span<const double> y_m,
                            std::span<const double> radius_m, double drum_radius_m,
                            const SurfaceParams& params);

}  // namespace biodem::analysis
