// Back-lit drum images (SPEC 6, video path): the drum is a bright disc on a darker background
// and the powder a dark shadow inside it. From one grey image: the disc, the powder mask, the
// centroid angle alpha (area-weighted over the shadow) and the free-surface fit of the shadow's
// upper boundary. Coordinates: pixel (row i, column j) has its centre at x = j, y = i (image y
// down); measures are converted to drum-centred coordinates with y up.
#pragma once
#include <cstddef>
#include <limits>
#include <optional>

#include <opencv2/core.hpp>

#include "analysis/free_surface.hpp"

namespace biodem::analysis {

struct DrumDisc {
  double cx_px;
  double cy_px;
  double radius_px;
};

/// Finds the bright drum disc: Otsu threshold of the (slightly blurred) image, largest bright
/// region, robust circle fit (RANSAC on its outer contour, then least squares on the inliers),
/// so that the straight chord of the powder surface does not bias the circle. Works for any fill
/// below ~70 %. Throws biodem::Error when no disc can be found.
DrumDisc find_drum_disc(const cv::Mat& gray);

enum class Rotation { ccw, cw };

struct FrameParams {
  Rotation rotation = Rotation::ccw;  // as seen in the image; cw mirrors x
  std::optional<int> threshold;       // raw grey level; <= threshold is powder (no flat field).
                                      // Default: Otsu of the flat-field corrected disc, per frame
  double rim_margin_px = -1.0;        // ignore this ring inside the rim; < 0: max(1.5 px, 0.5 % R)
  int min_contrast = 25;              // Otsu classes closer than this (corrected levels): no powder
  cv::Mat illumination;               // CV_32F back-light of the empty drum (flat field), e.g.
                                      // from background_illumination(); empty: fitted per frame
  double min_bed_fraction = 0.002;    // a largest dark region below this fraction of the disc
                                      // area is not a bed (dust on an empty drum): no powder
  int clean_px = -1;                  // opening/closing kernel; < 0: max(3, odd(R / 80)); 0: none
  ImageSurfaceParams surface;         // bin width, wall zone (mirror_x follows `rotation`)
};

struct FrameMeasure {
  bool has_powder = false;
  double alpha_deg;         // NaN without powder
  SurfaceFit surface;
  std::size_t powder_px = 0;
  int threshold = -1;       // grey level used
  double bed_light = std::numeric_limits<double>::quiet_NaN();  // the part of the light the bed
                            // passes: its mean flat-field corrected level over kLitLevel (NaN
                            // with a raw threshold or without powder)
};

/// Otsu threshold of the pixels where mask != 0; also returns the two class means.
int otsu_threshold(const cv::Mat& gray, const cv::Mat& mask, double* mean_dark = nullptr,
                   double* mean_bright = nullptr);

/// Filled disc mask (255 inside radius - margin).
cv::Mat disc_mask(cv::Size size, const DrumDisc& disc, double margin_px);

/// Level of the lit (empty) disc used in the flat-field corrected image: corrected = kLitLevel *
/// grey / illumination, so the empty drum is kLitLevel everywhere and the powder near 0.
inline constexpr double kLitLevel = 200.0;

/// Flat field from an empty-drum reference frame: the grey image as float, smoothed (Gaussian,
/// sigma max(1 px, R / 200)) so that its noise is not divided into every frame, at least 1.
cv::Mat background_illumination(const cv::Mat& gray, const DrumDisc& disc);

/// Back-light estimated from the frame itself: a smooth surface (full quadratic in x, y plus a
/// radial r^4 term about the disc centre) fitted by least squares to the lit pixels of the disc
/// (those above Otsu's threshold, refined once to those above 70 % of the first fit), evaluated
/// over the disc's bounding box. Follows vignetting and uneven back-light; CV_32F, at least 1.
cv::Mat estimate_illumination(const cv::Mat& gray, const DrumDisc& disc, double margin_px = -1.0);

/// Flat-field corrected image (CV_8U): kLitLevel * gray / illumination, saturated.
cv::Mat flat_field(const cv::Mat& gray, const cv::Mat& illumination);

/// Powder mask (255 = powder) inside the disc: threshold of the flat-field corrected image (Otsu
/// of the disc's pixels, or the raw --threshold), then morphological opening and closing (camera
/// noise, JPEG blocks, pinholes) and the largest 8-connected region (the bed: dust specks on the
/// end plates and grains in flight are dropped) with its holes filled; `threshold_used` receives the grey level, -1 when
/// the disc shows no contrast (no powder).
/// `bed_light` (when given) receives FrameMeasure::bed_light of the mask.
cv::Mat powder_mask(const cv::Mat& gray, const DrumDisc& disc, const FrameParams& params,
                    int* threshold_used = nullptr, double* bed_light = nullptr);

/// alpha (SPEC 6) of the area centroid of a powder mask; NaN if the mask is empty.
double mask_centroid_angle_deg(const cv::Mat& mask, const DrumDisc& disc, Rotation rotation);

/// Everything measured on one grey (CV_8UC1) frame.
FrameMeasure measure_backlit_frame(const cv::Mat& gray, const DrumDisc& disc,
                                   const FrameParams& params);

}  // namespace biodem::analysis
