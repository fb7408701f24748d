#include "output/speed_image.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <stdexcept>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace biodem::output {

namespace {

constexpr int kTitlePx = 30;  // the title's band above the drum
constexpr int kPanelPx = 130;  // the colour bar's band right of the drum
constexpr double kDiscFraction = 0.92;  // the drum's diameter over drum_px, as the back-lit frames
constexpr int kShift = 4;  // sub-pixel drawing, 1/16 px
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

// viridis at 0, 1/4, 1/2, 3/4, 1 (red, green, blue)
constexpr std::array<std::array<double, 3>, 5> kViridis{{
    {68.0, 1.0, 84.0}, {59.0, 82.0, 139.0}, {33.0, 145.0, 140.0}, {94.0, 201.0, 98.0}, {253.0, 231.0, 37.0}}};

cv::Scalar scalar(const std::array<std::uint8_t, 3>& c) { return cv::Scalar(c[0], c[1], c[2]); }

cv::Point fixed_point(double col, double row) {
  return {static_cast<int>(std::lround(col * (1 << kShift))), static_cast<int>(std::lround(row * (1 << kShift)))};
}

/// Tick step for about five ticks over [0, top]: 1, 2 or 5 times a power of ten.
double tick_step(double top) {
  const double raw = top / 5.0, p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0})
    if (m * p >= raw) return m * p;
  return 10.0 * p;
}

}  // namespace

std::array<std::uint8_t, 3> speed_colour_bgr(double fraction) {
  if (std::isnan(fraction)) return {128, 128, 128};
  const double f = std::clamp(fraction, 0.0, 1.0) * 4.0;
  const std::size_t k = std::min<std::size_t>(3, static_cast<std::size_t>(f));
  const double t = f - static_cast<double>(k);
  std::array<std::uint8_t, 3> bgr{};
  for (int c = 0; c < 3; ++c) {
    const double v = kViridis[k][c] + t * (kViridis[k + 1][c] - kViridis[k][c]);
    bgr[2 - c] = static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0, 255.0)));
  }
  return bgr;
}

SpeedImageGeometry speed_image_geometry(double drum_radius_m, const SpeedImageOptions& opt) {
  SpeedImageGeometry g;
  g.width = opt.drum_px + kPanelPx;
  g.height = opt.drum_px + kTitlePx;
  g.centre_col = 0.5 * (opt.drum_px - 1);
  g.centre_row = kTitlePx + 0.5 * (opt.drum_px - 1);
  g.disc_px = 0.5 * kDiscFraction * opt.drum_px;
  g.px_per_m = g.disc_px / drum_radius_m;
  g.bar_col0 = opt.drum_px + 16;
  g.bar_col1 = g.bar_col0 + 17;
  g.bar_row_top = kTitlePx + opt.drum_px / 8;
  g.bar_row_bottom = kTitlePx + opt.drum_px - opt.drum_px / 8;
  return g;
}

cv::Mat render_speed_image(std::span<const double> x_m, std::span<const double> y_m, std::span<const double> z_m,
                           std::span<const double> r_m, std::span<const double> speed_m_s, double drum_radius_m,
                           const SpeedImageOptions& opt) {
  const std::size_t n = x_m.size();
  if (y_m.size() != n || z_m.size() != n || r_m.size() != n || speed_m_s.size() != n)
    throw std::invalid_argument("render_speed_image: x, y, z, radius and speed differ in length");
  if (!(drum_radius_m > 0.0) || !(opt.max_speed_m_s > 0.0) || !std::isfinite(opt.max_speed_m_s) || opt.drum_px < 64)
    throw std::invalid_argument("render_speed_image: drum radius > 0, scale top > 0 and drum_px >= 64 needed");
  const SpeedImageGeometry g = speed_image_geometry(drum_radius_m, opt);
  cv::Mat img(g.height, g.width, CV_8UC3, cv::Scalar(255, 255, 255));

  // The drum: its inside light grey, the rim a dark ring just outside the wall.
  cv::circle(img, fixed_point(g.centre_col, g.centre_row), static_cast<int>(std::lround(g.disc_px * (1 << kShift))),
             cv::Scalar(235, 235, 235), cv::FILLED, cv::LINE_AA, kShift);
  cv::circle(img, fixed_point(g.centre_col, g.centre_row),
             static_cast<int>(std::lround((g.disc_px + 1.5) * (1 << kShift))), cv::Scalar(60, 60, 60), 2,
             cv::LINE_AA, kShift);

  // The spheres, farthest first (seen from +z: the nearest on top); equal z in input order.
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return z_m[a] < z_m[b]; });
  for (const std::size_t i : order) {
    if (!std::isfinite(x_m[i]) || !std::isfinite(y_m[i]) || !std::isfinite(r_m[i]) || !std::isfinite(z_m[i]))
      continue;
    const double r = std::max(0.5, r_m[i] * g.px_per_m);
    cv::circle(img, fixed_point(g.centre_col + x_m[i] * g.px_per_m, g.centre_row - y_m[i] * g.px_per_m),
               static_cast<int>(std::lround(r * (1 << kShift))),
               scalar(speed_colour_bgr(speed_m_s[i] / opt.max_speed_m_s)), cv::FILLED, cv::LINE_AA, kShift);
  }

  // The colour bar: the bottom row is speed 0, the top row the scale's top.
  const int rows = g.bar_row_bottom - g.bar_row_top;
  for (int row = g.bar_row_top; row <= g.bar_row_bottom; ++row) {
    const double f = static_cast<double>(g.bar_row_bottom - row) / rows;
    cv::line(img, {g.bar_col0, row}, {g.bar_col1, row}, scalar(speed_colour_bgr(f)), 1, cv::LINE_8);
  }
  cv::rectangle(img, {g.bar_col0 - 1, g.bar_row_top - 1}, {g.bar_col1 + 1, g.bar_row_bottom + 1},
                cv::Scalar(60, 60, 60), 1, cv::LINE_8);
  const double scale = 0.42;
  const double step = tick_step(opt.max_speed_m_s);
  char label[48];
  for (int k = 0;; ++k) {
    const double v = k * step;
    if (v > opt.max_speed_m_s * (1.0 + 1e-9)) break;
    const int row = g.bar_row_bottom - static_cast<int>(std::lround(v / opt.max_speed_m_s * rows));
    cv::line(img, {g.bar_col1 + 1, row}, {g.bar_col1 + 5, row}, cv::Scalar(60, 60, 60), 1, cv::LINE_8);
    std::snprintf(label, sizeof label, "%g", v);
    cv::putText(img, label, {g.bar_col1 + 8, row + 5}, kFont, scale, cv::Scalar(30, 30, 30), 1, cv::LINE_AA);
  }
  cv::putText(img, "speed, m/s", {g.bar_col0 - 8, g.bar_row_top - 22}, kFont, scale, cv::Scalar(30, 30, 30), 1,
              cv::LINE_AA);
  std::snprintf(label, sizeof label, "top >= %.3g", opt.max_speed_m_s);
  cv::putText(img, label, {g.bar_col0 - 8, g.bar_row_top - 8}, kFont, 0.36, cv::Scalar(30, 30, 30), 1,
              cv::LINE_AA);
  if (!opt.title.empty())
    cv::putText(img, opt.title, {8, kTitlePx - 10}, kFont, 0.5, cv::Scalar(30, 30, 30), 1, cv::LINE_AA);
  return img;
}

}  // namespace biodem::output
