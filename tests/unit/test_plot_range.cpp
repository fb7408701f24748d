// The x range of the plots (output/plot_writer.hpp): a plot of markers alone has head room at both
// ends along x (a marker at the data's first or last x is drawn whole, not cut by the plot area:
// the Pareto front's best point sat in the corner), and so has a plot of steps alone (a
// cumulative distribution's first and last steps are not drawn on the frame); a plot with a
// line runs from edge to edge.
// Read back from the SVG: the plot area's clip rectangle and the markers' centres.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "output/plot_writer.hpp"

namespace {

namespace fs = std::filesystem;
using biodem::output::Plot;
using biodem::output::PlotSeries;
using biodem::output::PlotStyle;

struct Drawn {
  double area_x = 0.0, area_w = 0.0;
  std::vector<double> cx;
};

Drawn draw(const Plot& p, const char* name) {
  const fs::path dir = fs::temp_directory_path() / "biodem_plot_range_test";
  fs::create_directories(dir);
  biodem::output::write_plot(p, dir / name);
  std::ifstream in(dir / (std::string(name) + ".svg"));
  const std::string svg((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  Drawn d;
  std::smatch m;
  const std::regex clip(R"re(<clipPath id="plot-area"><rect x="([-0-9.e]+)" y="[-0-9.e]+" width="([-0-9.e]+)")re");
  if (std::regex_search(svg, m, clip)) {
    d.area_x = std::stod(m[1]);
    d.area_w = std::stod(m[2]);
  }
  const std::regex circle(R"re(<circle cx="([-0-9.e]+)")re");
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), circle); it != std::sregex_iterator(); ++it)
    d.cx.push_back(std::stod((*it)[1]));
  return d;
}

}  // namespace

TEST(PlotRange, MarkersAloneHaveHeadRoomAlongXLinesDoNot) {
  Plot p;
  p.legend = biodem::output::LegendPlace::none;
  PlotSeries dots{"", {0.0, 2.0, 10.0}, {1.0, 3.0, 2.0}, PlotStyle::markers};
  p.series = {dots};
  const Drawn a = draw(p, "markers");
  ASSERT_GT(a.area_w, 100.0);
  ASSERT_EQ(a.cx.size(), 3u);
  // 4 % of the data's range each side: the first marker 0.04 / 1.08 of the width in
  EXPECT_NEAR(a.cx.front() - a.area_x, 0.04 / 1.08 * a.area_w, 1.0);
  EXPECT_NEAR(a.area_x + a.area_w - a.cx.back(), 0.04 / 1.08 * a.area_w, 1.0);

  p.series.push_back(PlotSeries{"", {0.0, 10.0}, {2.0, 2.0}, PlotStyle::line});
  const Drawn b = draw(p, "markers_and_line");
  ASSERT_EQ(b.cx.size(), 3u);
  EXPECT_NEAR(b.cx.front(), b.area_x, 0.5);
  EXPECT_NEAR(b.cx.back(), b.area_x + b.area_w, 0.5);
}

// Cumulative distributions (steps): 4 % head room each side, so that the step at the smallest
// value is inside the plot area, not on its left edge. Read from the step's path: its first x.
TEST(PlotRange, StepsHaveHeadRoomAlongX) {
  Plot p;
  p.legend = biodem::output::LegendPlace::none;
  p.series = {PlotSeries{"", {100.0, 104.0, 110.0}, {1.0 / 3.0, 2.0 / 3.0, 1.0}, PlotStyle::step}};
  const fs::path dir = fs::temp_directory_path() / "biodem_plot_range_test";
  fs::create_directories(dir);
  biodem::output::write_plot(p, dir / "steps");
  std::ifstream in(dir / "steps.svg");
  const std::string svg((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::smatch m;
  ASSERT_TRUE(std::regex_search(svg, m, std::regex(R"re(<clipPath id="plot-area"><rect x="([-0-9.e]+)" y="[-0-9.e]+" width="([-0-9.e]+)")re")));
  const double area_x = std::stod(m[1]), area_w = std::stod(m[2]);
  // The data is the polyline with the most points (grid lines and ticks have two); its left end.
  std::string best;
  const std::regex poly(R"re(<polyline[^>]*points="([^"]*)")re");
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), poly); it != std::sregex_iterator(); ++it)
    if (std::count((*it)[1].first, (*it)[1].second, ' ') > std::count(best.begin(), best.end(), ' ')) best = (*it)[1];
  ASSERT_FALSE(best.empty());
  double first_x = 1e300;
  std::stringstream pts(best);
  std::string pt;
  while (pts >> pt) first_x = std::min(first_x, std::stod(pt.substr(0, pt.find(','))));
  EXPECT_NEAR(first_x - area_x, 0.04 / 1.08 * area_w, 1.0);
}
