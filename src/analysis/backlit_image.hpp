// Back-lit drum images (SPEC 6, video path): the drum is a bright disc on a darker background
// and the powder a dark shadow inside it. From one grey image: the disc, the powder mask, the
// centroid angle alpha (area-weighted over the shadow) and the free-surface fit of the shadow's
// upper boundary. Coordinates: pixel (row i, column j) has its centre at x = j, y = i (image y
// down); measures are converted to drum-centred coordinates with y up.
#pragma once
#include <cstddef>
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
  std::optional<int> threshold;       // grey level; <= threshold is powder. Default: Otsu inside
                                      // the disc, per frame
  double rim_margin_px = -1.0;        // ignore this ring inside the rim; < 0: max(1.5 px, 0.5 % R)
  int min_contrast = 25;              // Otsu classes closer than this (grey levels): no powder
  ImageSurfaceParams surface;         // bin width, wall zone (mirror_x follows `rotation`)
};

struct FrameMeasure {
  bool has_powder = false;
  double alpha_deg;         // NaN without powder
  SurfaceFit surface;
  std::size_t powder_px = 0;
  int threshold = -1;       // grey level used
};

/// Otsu threshold of the pixels where mask != 0; also returns the two class means.
int otsu_threshold(const cv::Mat& gray, const cv::Mat& mask, double* mean_dark = nullptr,
                   double* mean_bright = nullptr);

/// Filled disc mask (255 inside radius - margin).
cv::Mat disc_mask(cv::Size size, const DrumDisc& disc, double margin_px);

/// Powder mask (255 = powder) inside the disc; `threshold_used` receives the grey level, -1 when
/// the disc shows no contrast (no powder).
cv::Mat powder_mask(const cv::Mat& gray, const DrumDisc& disc, const FrameParams& params,
                    int* threshold_used = nullptr);

/// alpha (SPEC 6) of the area centroid of a powder mask; NaN if the mask is empty.
double mask_centroid_angle_deg(const cv::Mat& mask, const DrumDisc& disc, Rotation rotation);

/// Everything measured on one grey (CV_8UC1) frame.
FrameMeasure measure_backlit_frame(const cv::Mat& gray, const DrumDisc& disc,
                                   const FrameParams& params);

}  // namespace biodem::analysis
