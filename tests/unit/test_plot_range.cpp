// The x range of the plots (output/plot_writer.hpp): a plot of markers alone has head room at both
// ends along x (a marker at the data's first or last x is drawn whole, not cut by the plot area:
// the Pareto front's best point sat in the corner), a plot with a line runs from edge to edge.
// Read back from the SVG: the plot area's clip rectangle and the markers' centres.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
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
