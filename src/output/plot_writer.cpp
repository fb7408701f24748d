#include "output/plot_writer.hpp"

#include "output/output_dir.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <memory>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "output/png_mat.hpp"

namespace biodem::output {

namespace {

struct Rgb {
  int r, g, b;
};

// matplotlib's "tab10", a palette readers know from the field's plots.
constexpr std::array<Rgb, 10> kPalette{{{31, 119, 180},
                                        {255, 127, 14},
                                        {44, 160, 44},
                                        {214, 39, 40},
                                        {148, 103, 189},
                                        {140, 86, 75},
                                        {227, 119, 194},
                                        {127, 127, 127},
                                        {188, 189, 34},
                                        {23, 190, 207}}};
constexpr Rgb kBlack{0, 0, 0};
constexpr Rgb kGrid{225, 225, 225};
constexpr Rgb kWhite{255, 255, 255};

enum class Anchor { start, middle, end };

using Pt = cv::Point2d;

class Canvas {
 public:
  virtual ~Canvas() = default;
  virtual void polyline(const std::vector<Pt>& pts, Rgb c, double width) = 0;
  virtual void marker(Pt p, Marker m, double size, Rgb c) = 0;
  virtual void rect(cv::Rect2d r, Rgb stroke, const Rgb* fill, double width) = 0;
  virtual void text(Pt p, const std::string& s, double size_px, Anchor a, bool vertical, Rgb c) = 0;
  virtual double text_width(const std::string& s, double size_px) = 0;
  virtual void begin_clip(cv::Rect2d r) = 0;
  virtual void end_clip() = 0;
};

// ---------------------------------------------------------------- SVG
std::string xml_escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '&': o += "&amp;"; break;
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '"': o += "&quot;"; break;
      default: o += c;
    }
  }
  return o;
}

std::string rgb(Rgb c) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", c.r, c.g, c.b);
  return buf;
}

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", v);
  return buf;
}

class SvgCanvas final : public Canvas {
 public:
  SvgCanvas(int w, int h) {
    o_ << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
       << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << w << "\" height=\"" << h
       << "\" viewBox=\"0 0 " << w << ' ' << h << "\" font-family=\"DejaVu Sans, Arial, sans-serif\">\n"
       << "<rect x=\"0\" y=\"0\" width=\"" << w << "\" height=\"" << h << "\" fill=\"#ffffff\"/>\n";
  }
  std::string finish() {
    o_ << "</svg>\n";
    return o_.str();
  }
  void polyline(const std::vector<Pt>& pts, Rgb c, double width) override {
    if (pts.size() < 2) return;
    o_ << "<polyline fill=\"none\" stroke=\"" << rgb(c) << "\" stroke-width=\"" << num(width)
       << "\" stroke-linejoin=\"round\" points=\"";
    for (const auto& p : pts) o_ << num(p.x) << ',' << num(p.y) << ' ';
    o_ << "\"/>\n";
  }
  void marker(Pt p, Marker m, double s, Rgb c) override {
    if (m == Marker::circle) {
      o_ << "<circle cx=\"" << num(p.x) << "\" cy=\"" << num(p.y) << "\" r=\"" << num(s)
         << "\" fill=\"" << rgb(c) << "\"/>\n";
      return;
    }
    const double d = m == Marker::triangle_down ? 1.0 : -1.0;
    o_ << "<polygon fill=\"" << rgb(c) << "\" points=\"" << num(p.x - s) << ',' << num(p.y - d * s)
       << ' ' << num(p.x + s) << ',' << num(p.y - d * s) << ' ' << num(p.x) << ','
       << num(p.y + d * s) << "\"/>\n";
  }
  void rect(cv::Rect2d r, Rgb stroke, const Rgb* fill, double width) override {
    o_ << "<rect x=\"" << num(r.x) << "\" y=\"" << num(r.y) << "\" width=\"" << num(r.width)
       << "\" height=\"" << num(r.height) << "\" fill=\"" << (fill ? rgb(*fill) : "none")
       << "\" stroke=\"" << rgb(stroke) << "\" stroke-width=\"" << num(width) << "\"/>\n";
  }
  void text(Pt p, const std::string& s, double size, Anchor a, bool vertical, Rgb c) override {
    const char* anchor = a == Anchor::start ? "start" : a == Anchor::middle ? "middle" : "end";
    o_ << "<text x=\"" << num(p.x) << "\" y=\"" << num(p.y) << "\" dy=\"0.35em\" font-size=\""
       << num(size) << "\" text-anchor=\"" << anchor << "\" fill=\"" << rgb(c) << '"';
    if (vertical) o_ << " transform=\"rotate(-90 " << num(p.x) << ' ' << num(p.y) << ")\"";
    o_ << '>' << xml_escape(s) << "</text>\n";
  }
  double text_width(const std::string& s, double size) override {
    return 0.58 * size * static_cast<double>(s.size());
  }
  void begin_clip(cv::Rect2d r) override {
    o_ << "<clipPath id=\"plot-area\"><rect x=\"" << num(r.x) << "\" y=\"" << num(r.y)
       << "\" width=\"" << num(r.width) << "\" height=\"" << num(r.height)
       << "\"/></clipPath>\n<g clip-path=\"url(#plot-area)\">\n";
  }
  void end_clip() override { o_ << "</g>\n"; }

 private:
  std::ostringstream o_;
};

// ---------------------------------------------------------------- raster (OpenCV)
constexpr int kShift = 3;  // sub-pixel drawing, 1/8 px
cv::Point fx(Pt p) {
  return {static_cast<int>(std::lround(p.x * (1 << kShift))),
          static_cast<int>(std::lround(p.y * (1 << kShift)))};
}
cv::Scalar bgr(Rgb c) { return cv::Scalar(c.b, c.g, c.r); }
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
double font_scale(double size_px) { return size_px / 30.0; }

class RasterCanvas final : public Canvas {
 public:
  RasterCanvas(int w, int h) : img_(h, w, CV_8UC3, cv::Scalar(255, 255, 255)), target_(img_) {}
  cv::Mat image() const { return img_; }
  void polyline(const std::vector<Pt>& pts, Rgb c, double width) override {
    if (pts.size() < 2) return;
    std::vector<cv::Point> q;
    q.reserve(pts.size());
    for (const auto& p : pts) q.push_back(fx(p - offset_));
    cv::polylines(target_, q, false, bgr(c), std::max(1, static_cast<int>(std::lround(width))),
                  cv::LINE_AA, kShift);
  }
  void marker(Pt p, Marker m, double s, Rgb c) override {
    p -= offset_;
    if (m == Marker::circle) {
      cv::circle(target_, fx(p), static_cast<int>(std::lround(s * (1 << kShift))), bgr(c),
                 cv::FILLED, cv::LINE_AA, kShift);
      return;
    }
    const double d = m == Marker::triangle_down ? 1.0 : -1.0;
    std::vector<cv::Point> tri{fx({p.x - s, p.y - d * s}), fx({p.x + s, p.y - d * s}),
                               fx({p.x, p.y + d * s})};
    cv::fillConvexPoly(target_, tri, bgr(c), cv::LINE_AA, kShift);
  }
  void rect(cv::Rect2d r, Rgb stroke, const Rgb* fill, double width) override {
    const cv::Point a = fx({r.x, r.y}), b = fx({r.x + r.width, r.y + r.height});
    if (fill) cv::rectangle(img_, a, b, bgr(*fill), cv::FILLED, cv::LINE_8, kShift);
    cv::rectangle(img_, a, b, bgr(stroke), std::max(1, static_cast<int>(std::lround(width))),
                  cv::LINE_8, kShift);
  }
  void text(Pt p, const std::string& s, double size, Anchor a, bool vertical, Rgb c) override {
    if (s.empty()) return;
    int base = 0;
    const double scale = font_scale(size);
    const cv::Size ts = cv::getTextSize(s, kFont, scale, 1, &base);
    if (!vertical) {
      double x = p.x;
      if (a == Anchor::middle) x -= ts.width / 2.0;
      if (a == Anchor::end) x -= ts.width;
      cv::putText(img_, s, cv::Point(static_cast<int>(std::lround(x)),
                                     static_cast<int>(std::lround(p.y + ts.height / 2.0))),
                  kFont, scale, bgr(c), 1, cv::LINE_AA);
      return;
    }
    // Vertical text: draw horizontally on a patch, turn it, darken the image with it.
    cv::Mat patch(ts.height + base + 4, ts.width + 4, CV_8UC3, cv::Scalar(255, 255, 255));
    cv::putText(patch, s, cv::Point(2, ts.height + 2), kFont, scale, bgr(c), 1, cv::LINE_AA);
    cv::Mat turned;
    cv::rotate(patch, turned, cv::ROTATE_90_COUNTERCLOCKWISE);
    double y = p.y - turned.rows / 2.0;
    if (a == Anchor::start) y = p.y - turned.rows;
    if (a == Anchor::end) y = p.y;
    cv::Rect dst(static_cast<int>(std::lround(p.x - turned.cols / 2.0)),
                 static_cast<int>(std::lround(y)), turned.cols, turned.rows);
    const cv::Rect clipped = dst & cv::Rect(0, 0, img_.cols, img_.rows);
    if (clipped.area() <= 0) return;
    cv::Mat src = turned(cv::Rect(clipped.x - dst.x, clipped.y - dst.y, clipped.width, clipped.height));
    cv::Mat roi = img_(clipped);
    cv::min(roi, src, roi);
  }
  double text_width(const std::string& s, double size) override {
    int base = 0;
    return cv::getTextSize(s, kFont, font_scale(size), 1, &base).width;
  }
  void begin_clip(cv::Rect2d r) override {
    const cv::Rect ri = cv::Rect(cv::Point(static_cast<int>(std::floor(r.x)), static_cast<int>(std::floor(r.y))),
                                 cv::Point(static_cast<int>(std::ceil(r.x + r.width)) + 1,
                                           static_cast<int>(std::ceil(r.y + r.height)) + 1)) &
                        cv::Rect(0, 0, img_.cols, img_.rows);
    target_ = img_(ri);
    offset_ = Pt(ri.x, ri.y);
  }
  void end_clip() override {
    target_ = img_;
    offset_ = Pt(0, 0);
  }

 private:
  cv::Mat img_;
  cv::Mat target_;
  Pt offset_{0, 0};
};

// ---------------------------------------------------------------- layout
struct Range {
  double lo, hi;
};

Range data_range(const Plot& p, bool x_axis) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto& s : p.series)
    for (double v : x_axis ? s.x : s.y)
      if (std::isfinite(v)) {
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
  const auto& want_lo = x_axis ? p.x_min : p.y_min;
  const auto& want_hi = x_axis ? p.x_max : p.y_max;
  if (!std::isfinite(lo)) {
    lo = 0.0;
    hi = 1.0;
  }
  if (want_lo) lo = *want_lo;
  if (want_hi) hi = *want_hi;
  if (!(hi > lo)) {
    const double pad = std::max(0.5, 0.05 * std::abs(lo));
    lo -= pad;
    hi += pad;
  } else if (!x_axis || std::all_of(p.series.begin(), p.series.end(), [](const PlotSeries& s) {
               return s.style == PlotStyle::markers || s.style == PlotStyle::step;
             })) {
    // A little head room above and below the data, none where the user fixed a limit; along x
    // only in plots of markers or steps alone (a marker at the data's end is not cut in half
    // there, and a cumulative distribution's first and last steps are not drawn on the frame;
    // a line over time runs from edge to edge).
    const double pad = 0.04 * (hi - lo);
    if (!want_lo) lo -= pad;
    if (!want_hi) hi += pad;
  }
  return {lo, hi};
}

std::string tick_label(double v, double step) {
  // Enough decimals to show the step exactly (0.25 needs two, 2.5 one, 50 none).
  int decimals = 0;
  while (decimals < 8) {
    const double scaled = step * std::pow(10.0, decimals);
    if (std::abs(scaled - std::round(scaled)) < 1e-6 * std::max(1.0, scaled)) break;
    ++decimals;
  }
  if (std::abs(v) < step * 1e-9) v = 0.0;
  char buf[48];
  if (std::abs(v) >= 1e6 || (std::abs(v) > 0 && std::abs(v) < 1e-4))
    std::snprintf(buf, sizeof buf, "%.3g", v);
  else
    std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// Keeps at most ~4 points per pixel column (first, min, max, last), in order: the drawn line
// looks the same and the SVG stays small for long series.
std::vector<Pt> decimate(const std::vector<Pt>& pts, double width_px) {
  if (pts.size() < static_cast<std::size_t>(8.0 * width_px)) return pts;
  std::vector<Pt> out;
  std::size_t i = 0;
  while (i < pts.size()) {
    const long col = std::lround(std::floor(pts[i].x));
    std::size_t j = i, imin = i, imax = i;
    while (j < pts.size() && std::lround(std::floor(pts[j].x)) == col) {
      if (pts[j].y < pts[imin].y) imin = j;
      if (pts[j].y > pts[imax].y) imax = j;
      ++j;
    }
    std::array<std::size_t, 4> keep{i, imin, imax, j - 1};
    std::sort(keep.begin(), keep.end());
    for (std::size_t k = 0; k < keep.size(); ++k)
      if (k == 0 || keep[k] != keep[k - 1]) out.push_back(pts[keep[k]]);
    i = j;
  }
  return out;
}

// The plot area inside the margins (the same for every canvas).
cv::Rect2d plot_area(const Plot& p) {
  const double W = p.width_px, H = p.height_px;
  const double left = 78.0, right = 22.0, top = p.note.empty() ? 40.0 : 56.0, bottom = 58.0;
  return {left, top, W - left - right, H - top - bottom};
}

// The legend box at a corner of the area, for a box of bw x bh pixels.
cv::Rect2d legend_box(const cv::Rect2d& area, LegendPlace place, double bw, double bh) {
  const bool left = place == LegendPlace::top_left || place == LegendPlace::bottom_left;
  const bool bottom = place == LegendPlace::bottom_right || place == LegendPlace::bottom_left;
  return {left ? area.x + 8.0 : area.x + area.width - bw - 8.0, bottom ? area.y + area.height - bh - 8.0 : area.y + 8.0,
          bw, bh};
}

}  // namespace

LegendPlace resolved_legend(const Plot& p) {
  if (p.legend != LegendPlace::automatic) return p.legend;
  const cv::Rect2d area = plot_area(p);
  const Range xr = data_range(p, true), yr = data_range(p, false);
  std::size_t entries = 0, chars = 0;
  for (const auto& s : p.series)
    if (!s.label.empty()) {
      ++entries;
      chars = std::max(chars, s.label.size());
    }
  // The box's size as draw() makes it, with the text width estimated (6.5 px a character at 11 px).
  const double bw = 6.5 * static_cast<double>(chars) + 44.0, bh = 17.0 * static_cast<double>(entries) + 8.0;
  LegendPlace best = LegendPlace::top_right;
  std::size_t fewest = std::numeric_limits<std::size_t>::max();
  for (LegendPlace place : {LegendPlace::top_right, LegendPlace::top_left, LegendPlace::bottom_right, LegendPlace::bottom_left}) {
    const cv::Rect2d b = legend_box(area, place, bw, bh);
    std::size_t covered = 0;
    for (const auto& s : p.series)
      for (std::size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i) {
        if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
        const double x = area.x + (s.x[i] - xr.lo) / (xr.hi - xr.lo) * area.width;
        const double y = area.y + area.height - (s.y[i] - yr.lo) / (yr.hi - yr.lo) * area.height;
        if (x >= b.x && x <= b.x + b.width && y >= b.y && y <= b.y + b.height) ++covered;
      }
    if (covered < fewest) {
      fewest = covered;
      best = place;
    }
  }
  return best;
}

namespace {

void draw(const Plot& p, Canvas& c) {
  const double W = p.width_px, H = p.height_px;
  const double font = 13.0, small = 11.0;
  const cv::Rect2d area = plot_area(p);
  const Range xr = data_range(p, true), yr = data_range(p, false);
  auto X = [&](double v) { return area.x + (v - xr.lo) / (xr.hi - xr.lo) * area.width; };
  auto Y = [&](double v) { return area.y + area.height - (v - yr.lo) / (yr.hi - yr.lo) * area.height; };

  // Grid and ticks.
  const auto xt = nice_ticks(xr.lo, xr.hi), yt = nice_ticks(yr.lo, yr.hi);
  const double xstep = xt.size() > 1 ? xt[1] - xt[0] : 1.0, ystep = yt.size() > 1 ? yt[1] - yt[0] : 1.0;
  for (double v : xt) c.polyline({{X(v), area.y}, {X(v), area.y + area.height}}, kGrid, 1.0);
  for (double v : yt) c.polyline({{area.x, Y(v)}, {area.x + area.width, Y(v)}}, kGrid, 1.0);

  // Data, clipped to the plot area.
  c.begin_clip(area);
  for (std::size_t k = 0; k < p.series.size(); ++k) {
    const auto& s = p.series[k];
    const Rgb col = kPalette[static_cast<std::size_t>(s.color >= 0 ? s.color : static_cast<int>(k)) % kPalette.size()];
    const std::size_t n = std::min(s.x.size(), s.y.size());
    if (s.style == PlotStyle::markers) {
      for (std::size_t i = 0; i < n; ++i)
        if (std::isfinite(s.x[i]) && std::isfinite(s.y[i]))
          c.marker({X(s.x[i]), Y(s.y[i])}, s.marker, s.marker_size, col);
      continue;
    }
    // Lines break at non-finite values.
    std::vector<Pt> run;
    auto flush = [&] {
      c.polyline(decimate(run, area.width), col, s.line_width);
      run.clear();
    };
    for (std::size_t i = 0; i < n; ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
        flush();
        continue;
      }
      if (s.style == PlotStyle::step) {
        // Empirical CDF: rise at each value, flat in between; starts from the floor of the axis.
        const double prev_px = run.empty() ? Y(std::max(yr.lo, 0.0)) : run.back().y;
        run.push_back({X(s.x[i]), prev_px});
      }
      run.push_back({X(s.x[i]), Y(s.y[i])});
    }
    flush();
  }
  c.end_clip();

  // Frame, ticks, labels.
  c.rect(area, kBlack, nullptr, 1.0);
  for (double v : xt) {
    c.polyline({{X(v), area.y + area.height}, {X(v), area.y + area.height + 5}}, kBlack, 1.0);
    c.text({X(v), area.y + area.height + 16}, tick_label(v, xstep), small, Anchor::middle, false, kBlack);
  }
  for (double v : yt) {
    c.polyline({{area.x - 5, Y(v)}, {area.x, Y(v)}}, kBlack, 1.0);
    c.text({area.x - 8, Y(v)}, tick_label(v, ystep), small, Anchor::end, false, kBlack);
  }
  c.text({area.x + area.width / 2, H - 16}, p.x_label, font, Anchor::middle, false, kBlack);
  c.text({18, area.y + area.height / 2}, p.y_label, font, Anchor::middle, true, kBlack);
  c.text({W / 2, 20}, p.title, 15.0, Anchor::middle, false, kBlack);
  if (!p.note.empty()) c.text({W / 2, 40}, p.note, small, Anchor::middle, false, {80, 80, 80});

  // Legend.
  std::vector<std::size_t> entries;
  for (std::size_t k = 0; k < p.series.size(); ++k)
    if (!p.series[k].label.empty()) entries.push_back(k);
  const LegendPlace place = resolved_legend(p);
  if (place == LegendPlace::none || entries.empty()) return;
  double tw = 0.0;
  for (auto k : entries) tw = std::max(tw, c.text_width(p.series[k].label, small));
  const double row = 17.0, bw = tw + 44.0, bh = row * static_cast<double>(entries.size()) + 8.0;
  const cv::Rect2d box = legend_box(area, place, bw, bh);
  const double bx = box.x, by = box.y;
  c.rect({bx, by, bw, bh}, {160, 160, 160}, &kWhite, 1.0);
  for (std::size_t e = 0; e < entries.size(); ++e) {
    const auto& s = p.series[entries[e]];
    const Rgb col = kPalette[static_cast<std::size_t>(s.color >= 0 ? s.color : static_cast<int>(entries[e])) % kPalette.size()];
    const double y = by + 4.0 + row * (static_cast<double>(e) + 0.5);
    if (s.style == PlotStyle::markers)
      c.marker({bx + 18, y}, s.marker, s.marker_size, col);
    else
      c.polyline({{bx + 8, y}, {bx + 30, y}}, col, std::max(1.5, s.line_width));
    c.text({bx + 36, y}, s.label, small, Anchor::start, false, kBlack);
  }
}

}  // namespace

std::vector<double> nice_ticks(double lo, double hi, int target) {
  std::vector<double> t;
  if (!(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi)) return t;
  const double raw = (hi - lo) / std::max(1, target);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
    if (m * mag >= raw) {
      step = m * mag;
      break;
    }
  const double first = std::ceil(lo / step - 1e-9) * step;
  for (double v = first; v <= hi + 1e-9 * step; v += step) t.push_back(v);
  return t;
}

std::string plot_to_svg(const Plot& plot) {
  SvgCanvas c(plot.width_px, plot.height_px);
  draw(plot, c);
  return c.finish();
}

cv::Mat plot_to_image(const Plot& plot) {
  RasterCanvas c(plot.width_px, plot.height_px);
  draw(plot, c);
  return c.image();
}

void write_plot(const Plot& plot, const std::filesystem::path& stem) {
  auto svg_path = stem;
  svg_path += ".svg";
  auto png_path = stem;
  png_path += ".png";
  write_file_atomic(svg_path.string(), plot_to_svg(plot));
  write_png(png_path.string(), plot_to_image(plot));
}

}  // namespace biodem::output
