#include "analysis/free_surface.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <optional>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "analysis/backlit_image.hpp"
#include "analysis/render_frame.hpp"

namespace biodem::analysis {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Longest run of consecutive bins that hold a point: the surface between the two contacts of
// the bed with the mantle (isolated points beyond a gap, e.g. powder stuck high on the wall but
// outside the wall zone, are not part of it).
std::vector<ProfilePoint> longest_run(const std::vector<std::optional<ProfilePoint>>& bins) {
  std::size_t best_begin = 0, best_len = 0, begin = 0, len = 0;
  for (std::size_t k = 0; k < bins.size(); ++k) {
    if (bins[k]) {
      if (len == 0) begin = k;
      ++len;
      if (len > best_len) {
        best_len = len;
        best_begin = begin;
      }
    } else {
      len = 0;
    }
  }
  std::vector<ProfilePoint> out;
  out.reserve(best_len);
  for (std::size_t k = best_begin; k < best_begin + best_len; ++k) out.push_back(*bins[k]);
  return out;
}

}  // namespace

SurfaceFit fit_surface_line(std::span<const ProfilePoint> pts) {
  const std::size_t n = pts.size();
  if (n < 3) return SurfaceFit{kNaN, kNaN, n, false};
  double mx = 0.0, my = 0.0;
  for (const auto& q : pts) {
    mx += q.x;
    my += q.y;
  }
  mx /= static_cast<double>(n);
  my /= static_cast<double>(n);
  double sxx = 0.0, sxy = 0.0, syy = 0.0, scale = 0.0;
  for (const auto& q : pts) {
    const double dx = q.x - mx, dy = q.y - my;
    sxx += dx * dx;
    sxy += dx * dy;
    syy += dy * dy;
    scale = std::max({scale, std::abs(q.x), std::abs(q.y)});
  }
  if (!(sxx > 0.0)) return SurfaceFit{kNaN, kNaN, n, false};  // all points in one column
  const double slope = sxy / sxx;
  const double ss_res = std::max(0.0, syy - slope * sxy);
  // Heights equal to rounding: a perfect (horizontal) straight line.
  const double tiny = 1e-24 * scale * scale * static_cast<double>(n);
  const double r2 = syy <= tiny ? 1.0 : 1.0 - ss_res / syy;
  const double angle = std::atan(slope) * 180.0 / std::numbers::pi;
  return SurfaceFit{r2, angle, n, true};
}

SurfaceParams SurfaceParams::for_frames(int frame_size_px) {
  SurfaceParams p;
  p.raster_px = frame_size_px;
  return p;
}

SurfaceFit fit_free_surface(std::span<const double> x_m, std::span<const double> y_m,
                            std::span<const double> radius_m, double drum_radius_m,
                            const SurfaceParams& params) {
  if (params.raster_px < 16) throw std::invalid_argument("fit_free_surface: raster must be >= 16 px");
  const BacklitStyle style{};
  const cv::Mat frame = render_backlit_frame(x_m, y_m, radius_m, drum_radius_m, params.raster_px, style);
  FrameParams fp;
  fp.surface = params.image;
  // (measure_backlit_frame mirrors the profile by the rotation: a clockwise drum's mirror_x)
  fp.rotation = params.image.mirror_x ? Rotation::cw : Rotation::ccw;
  // The grey levels of a rendered frame are known: the midpoint between the particles' and the
  // lit disc's level is the threshold (what Otsu finds on such a frame, without estimating the
  // back-light: the render costs less per sample).
  fp.threshold = (style.particle + style.disc) / 2;
  return measure_backlit_frame(frame, rendered_disc(params.raster_px, style), fp).surface;
}

std::vector<ProfilePoint> free_surface_profile_mask(const cv::Mat& mask, double cx, double cy,
                                                    double R, const ImageSurfaceParams& p) {
  if (mask.empty() || mask.type() != CV_8UC1)
    throw std::invalid_argument("free_surface_profile_mask: mask must be a non-empty CV_8UC1");
  if (!(R > 0.0) || p.bin_px < 1)
    throw std::invalid_argument("free_surface_profile_mask: radius and bin width must be > 0");
  const double wall = p.wall_zone_px < 0.0 ? 0.05 * R : p.wall_zone_px;

  // The bed is the largest connected powder region; detached grains in flight are not surface.
  cv::Mat labels, stats, centroids;
  const int n_labels = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  int bed = -1, bed_area = 0;
  for (int l = 1; l < n_labels; ++l) {
    const int a = stats.at<int>(l, cv::CC_STAT_AREA);
    if (a > bed_area) {
      bed_area = a;
      bed = l;
    }
  }
  if (bed < 0) return {};

  const int col0 = std::max(0, static_cast<int>(std::floor(cx - R)));
  const int col1 = std::min(mask.cols - 1, static_cast<int>(std::ceil(cx + R)));
  const int row0 = stats.at<int>(bed, cv::CC_STAT_TOP);
  const int row1 = row0 + stats.at<int>(bed, cv::CC_STAT_HEIGHT) - 1;
  const double gap = p.max_gap_px < 0.0 ? std::max(2.0, 0.05 * R) : p.max_gap_px;
  // Per column, climb from the lowest bed pixel through gaps of at most `gap` pixels; the top
  // reached is the surface (same rule as for particles).
  std::vector<int> top_row(static_cast<std::size_t>(mask.cols), -1);
  for (int j = col0; j <= col1; ++j) {
    int top = -1;
    for (int i = row1; i >= row0; --i) {
      if (labels.at<int>(i, j) != bed) continue;
      if (top >= 0 && top - i - 1 > gap) break;
      top = i;
    }
    top_row[static_cast<std::size_t>(j)] = top;
  }

  const int n_bins = (col1 - col0) / p.bin_px + 1;
  std::vector<std::optional<ProfilePoint>> bins(static_cast<std::size_t>(n_bins));
  for (int b = 0; b < n_bins; ++b) {
    std::optional<ProfilePoint> best;
    for (int j = col0 + b * p.bin_px; j < std::min(col1 + 1, col0 + (b + 1) * p.bin_px); ++j) {
      const int i = top_row[static_cast<std::size_t>(j)];
      if (i < 0) continue;
      const double x = static_cast<double>(j) - cx;
      const double y = cy - static_cast<double>(i) + 0.5;  // top edge of the pixel, y up
      if (std::hypot(x, y) > R - wall) continue;
      if (!best || y > best->y) best = ProfilePoint{p.mirror_x ? -x : x, y};
    }
    bins[static_cast<std::size_t>(b)] = best;
  }
  auto profile = longest_run(bins);
  if (p.mirror_x) std::reverse(profile.begin(), profile.end());
  return profile;
}

SurfaceFit fit_free_surface_mask(const cv::Mat& mask, double cx_px, double cy_px,
                                 double radius_px, const ImageSurfaceParams& params) {
  const auto profile = free_surface_profile_mask(mask, cx_px, cy_px, radius_px, params);
  return fit_surface_line(profile);
}

}  // namespace biodem::analysis
