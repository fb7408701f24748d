#include "analysis/render_frame.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace biodem::analysis {

cv::Mat render_backlit_frame(std::span<const double> x_m, std::span<const double> y_m,
                             std::span<const double> r_m, double drum_radius_m, int size_px,
                             const BacklitStyle& style) {
  if (x_m.size() != y_m.size() || x_m.size() != r_m.size())
    throw std::invalid_argument("render_backlit_frame: x, y and radius differ in length");
  if (!(drum_radius_m > 0.0) || size_px < 16)
    throw std::invalid_argument("render_backlit_frame: drum radius > 0 and size >= 16 px needed");

  cv::Mat img(size_px, size_px, CV_8UC1, cv::Scalar(style.background));
  // Sub-pixel drawing: coordinates in 1/16 px.
  constexpr int kShift = 4;
  constexpr double kScale = 1 << kShift;
  const double c = 0.5 * (size_px - 1);
  const double disc_px = 0.5 * style.disc_fraction * size_px;
  const double px_per_m = disc_px / drum_radius_m;
  auto pt = [&](double x, double y) {
    return cv::Point(static_cast<int>(std::lround((c + x * px_per_m) * kScale)),
                     static_cast<int>(std::lround((c - y * px_per_m) * kScale)));
  };
  cv::circle(img, pt(0.0, 0.0), static_cast<int>(std::lround(disc_px * kScale)),
             cv::Scalar(style.disc), cv::FILLED, cv::LINE_AA, kShift);
  for (std::size_t i = 0; i < x_m.size(); ++i) {
    if (!std::isfinite(x_m[i]) || !std::isfinite(y_m[i]) || !std::isfinite(r_m[i])) continue;
    const double r = std::max(0.5, r_m[i] * px_per_m);
    cv::circle(img, pt(x_m[i], y_m[i]), static_cast<int>(std::lround(r * kScale)),
               cv::Scalar(style.particle), cv::FILLED, cv::LINE_AA, kShift);
  }
  return img;
}

cv::Mat render_backlit_frame(std::span<const double> x_m, std::span<const double> y_m,
                             std::span<const double> r_m, double drum_radius_m, int size_px) {
  return render_backlit_frame(x_m, y_m, r_m, drum_radius_m, size_px, BacklitStyle{});
}

DrumDisc rendered_disc(int size_px, const BacklitStyle& style) {
  const double c = 0.5 * (size_px - 1);
  return DrumDisc{c, c, 0.5 * style.disc_fraction * size_px};
}

}  // namespace biodem::analysis
