// Small 2-D plots written as SVG (text, written directly) and PNG (drawn with OpenCV), so plots
// need nothing beyond the libraries the build already links (no Python, no gnuplot). Axes with
// "nice" ticks (1, 2, 5 x 10^k), grid, tick labels, axis labels, title and legend. Text should be
// ASCII (the raster font has no other glyphs).
#pragma once
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#if BIODEM_HAVE_OPENCV
#include <opencv2/core.hpp>
#endif

namespace biodem::output {

enum class PlotStyle { line, step, markers };
enum class Marker { circle, triangle_down, triangle_up };
/// Where the legend box goes; `automatic`: the corner of the plot area that covers the fewest
/// data points (ties in the order top right, top left, bottom right, bottom left).
enum class LegendPlace { none, top_left, top_right, bottom_right, bottom_left, automatic };

struct PlotSeries {
  std::string label;  // legend entry; empty: not in the legend
  std::vector<double> x;
  std::vector<double> y;
  PlotStyle style = PlotStyle::line;
  Marker marker = Marker::circle;
  int color = -1;             // index in a 10-colour palette; -1: the series' position
  double line_width = 1.5;    // px
  double marker_size = 4.0;   // px
};

struct Plot {
  std::string title;
  std::string x_label;
  std::string y_label;
  std::vector<PlotSeries> series;
  std::optional<double> x_min, x_max, y_min, y_max;  // default: data range
  LegendPlace legend = LegendPlace::top_right;
  int width_px = 900;
  int height_px = 560;
  std::string note;  // small text under the title (e.g. threshold used); optional
};

/// The corner `automatic` resolves to for this plot (any other place is returned as it is).
LegendPlace resolved_legend(const Plot& plot);

/// SVG document of the plot.
std::string plot_to_svg(const Plot& plot);
/// 8-bit BGR image of the plot.
#if BIODEM_HAVE_OPENCV
cv::Mat plot_to_image(const Plot& plot);
#endif
/// Writes STEM.svg and STEM.png (STEM without extension). Throws biodem::Error on failure.
void write_plot(const Plot& plot, const std::filesystem::path& stem);
/// False in the lean build without OpenCV (docs/gpu.md): analyze and compare then write no plots.
constexpr bool plots_built() {
#if BIODEM_HAVE_OPENCV
  return true;
#else
  return false;
#endif
}

/// Tick positions ("nice" numbers) covering [lo, hi] with about `target` ticks.
std::vector<double> nice_ticks(double lo, double hi, int target = 6);

}  // namespace biodem::output
