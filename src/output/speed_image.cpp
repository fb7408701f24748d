#include "output/speed_image.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>
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
  g.bar_row_top = kTitlePx + std::max(opt.drum_px / 8, 56);
  g.bar_row_bottom = kTitlePx + opt.drum_px - std::max(opt.drum_px / 8, 24);
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
  const cv::Scalar ink(30, 30, 30), rim(60, 60, 60);

  // The drum: its inside light grey, the rim a dark ring just outside the wall.
  cv::circle(img, fixed_point(g.centre_col, g.centre_row), static_cast<int>(std::lround(g.disc_px * (1 << kShift))),
             cv::Scalar(235, 235, 235), cv::FILLED, cv::LINE_AA, kShift);
  cv::circle(img, fixed_point(g.centre_col, g.centre_row),
             static_cast<int>(std::lround((g.disc_px + 1.5) * (1 << kShift))), rim, 2, cv::LINE_AA, kShift);

  // The spheres, farthest first (seen from +z: the nearest on top; equal depths in input order).
  // Only finite ones (a NaN depth would break the sort's order).
  std::vector<std::pair<double, std::size_t>> order;
  order.reserve(n);
  std::size_t above = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(x_m[i]) || !std::isfinite(y_m[i]) || !std::isfinite(z_m[i]) || !std::isfinite(r_m[i]) ||
        !std::isfinite(speed_m_s[i]))
      continue;
    const double depth = opt.period_z_m > 0.0 ? z_m[i] - opt.period_z_m * std::floor(z_m[i] / opt.period_z_m) : z_m[i];
    order.emplace_back(depth, i);
    if (speed_m_s[i] > opt.max_speed_m_s) ++above;
  }
  std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [depth, i] : order) {
    const double r = std::max(0.5, r_m[i] * g.px_per_m);
    cv::circle(img, fixed_point(g.centre_col + x_m[i] * g.px_per_m, g.centre_row - y_m[i] * g.px_per_m),
               static_cast<int>(std::lround(r * (1 << kShift))),
               scalar(speed_colour_bgr(speed_m_s[i] / opt.max_speed_m_s)), cv::FILLED, cv::LINE_AA, kShift);
  }

  // The colour bar: the bottom row is speed 0, the top row the scale's top; above it a triangle
  // in the top colour stands for the speeds beyond the scale.
  const int rows = g.bar_row_bottom - g.bar_row_top;
  for (int row = g.bar_row_top; row <= g.bar_row_bottom; ++row) {
    const double f = static_cast<double>(g.bar_row_bottom - row) / rows;
    cv::line(img, {g.bar_col0, row}, {g.bar_col1, row}, scalar(speed_colour_bgr(f)), 1, cv::LINE_8);
  }
  cv::rectangle(img, {g.bar_col0 - 1, g.bar_row_top - 1}, {g.bar_col1 + 1, g.bar_row_bottom + 1}, rim, 1,
                cv::LINE_8);
  const std::vector<cv::Point> over{{g.bar_col0 - 1, g.bar_row_top - 2},
                                    {g.bar_col1 + 1, g.bar_row_top - 2},
                                    {(g.bar_col0 + g.bar_col1) / 2, g.bar_row_top - 14}};
  cv::fillConvexPoly(img, over, scalar(speed_colour_bgr(1.0)), cv::LINE_AA);
  cv::polylines(img, over, true, rim, 1, cv::LINE_AA);
  const double scale = 0.42;
  const double step = tick_step(opt.max_speed_m_s);
  char label[48];
  auto tick = [&](double v, int row) {
    cv::line(img, {g.bar_col1 + 1, row}, {g.bar_col1 + 5, row}, rim, 1, cv::LINE_8);
    std::snprintf(label, sizeof label, "%.3g", v);
    cv::putText(img, label, {g.bar_col1 + 8, row + 5}, kFont, scale, ink, 1, cv::LINE_AA);
  };
  for (int k = 0;; ++k) {  // round ticks, none too close under the top's own label
    const double v = k * step;
    if (v > 0.88 * opt.max_speed_m_s) break;
    tick(v, g.bar_row_bottom - static_cast<int>(std::lround(v / opt.max_speed_m_s * rows)));
  }
  tick(opt.max_speed_m_s, g.bar_row_top);
  cv::putText(img, "speed, m/s", {g.bar_col0 - 8, g.bar_row_top - 24}, kFont, scale, ink, 1, cv::LINE_AA);

  // The title, with the spheres beyond the scale; smaller type where it would not fit.
  std::string title = opt.title;
  if (above > 0) title += (title.empty() ? "" : ", ") + std::to_string(above) + " faster than the scale";
  if (!title.empty()) {
    double ts = 0.5;
    int base = 0;
    while (ts > 0.25 && cv::getTextSize(title, kFont, ts, 1, &base).width > g.width - 16) ts *= 0.9;
    cv::putText(img, title, {8, kTitlePx - 10}, kFont, ts, ink, 1, cv::LINE_AA);
  }
  return img;
}

}  // namespace biodem::output
