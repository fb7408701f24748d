// The cross-sections coloured by speed (output/speed_image.hpp; SPEC 6, "snapshots coloured by
// speed"): the colour map at its stops and beyond them, where a sphere lands (signs of x and y),
// which of two overlapping spheres is seen (the nearer, larger z, whatever the input order), the
// colour bar's ends, the default scale, and the bad arguments.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "output/speed_image.hpp"

namespace {

using biodem::output::render_speed_image;
using biodem::output::speed_colour_bgr;
using biodem::output::speed_image_geometry;
using biodem::output::SpeedImageOptions;
using Bgr = std::array<std::uint8_t, 3>;

Bgr pixel(const cv::Mat& img, double col, double row) {
  const auto& p = img.at<cv::Vec3b>(static_cast<int>(std::lround(row)), static_cast<int>(std::lround(col)));
  return {p[0], p[1], p[2]};
}

SpeedImageOptions options(int drum_px, double max_speed_m_s) {
  SpeedImageOptions o;
  o.drum_px = drum_px;
  o.max_speed_m_s = max_speed_m_s;
  return o;
}

struct Scene {
  std::vector<double> x, y, z, r, v;
  void add(double xi, double yi, double zi, double ri, double vi) {
    x.push_back(xi);
    y.push_back(yi);
    z.push_back(zi);
    r.push_back(ri);
    v.push_back(vi);
  }
  cv::Mat render(const SpeedImageOptions& o, double drum_r = 0.1) const { return render_speed_image(x, y, z, r, v, drum_r, o); }
};

}  // namespace

TEST(SpeedImage, ColourMapHasTheViridisStopsAndClipsOutsideTheScale) {
  // viridis at 0, 1/4, 1/2, 3/4, 1 in red, green, blue: written here as blue, green, red
  EXPECT_EQ(speed_colour_bgr(0.0), (Bgr{84, 1, 68}));
  EXPECT_EQ(speed_colour_bgr(0.25), (Bgr{139, 82, 59}));
  EXPECT_EQ(speed_colour_bgr(0.5), (Bgr{140, 145, 33}));
  EXPECT_EQ(speed_colour_bgr(0.75), (Bgr{98, 201, 94}));
  EXPECT_EQ(speed_colour_bgr(1.0), (Bgr{37, 231, 253}));
  // halfway between the first two stops: (68 + 59) / 2 = 63.5, (1 + 82) / 2 = 41.5, (84 + 139) / 2 = 111.5
  EXPECT_EQ(speed_colour_bgr(0.125), (Bgr{112, 42, 64}));
  EXPECT_EQ(speed_colour_bgr(-3.0), speed_colour_bgr(0.0));
  EXPECT_EQ(speed_colour_bgr(7.0), speed_colour_bgr(1.0));
  EXPECT_EQ(speed_colour_bgr(std::numeric_limits<double>::infinity()), speed_colour_bgr(1.0));
  EXPECT_EQ(speed_colour_bgr(std::numeric_limits<double>::quiet_NaN()), (Bgr{128, 128, 128}));
  // brighter (sum of the channels) as the speed rises, so a grey print still orders them
  int last = -1;
  for (int k = 0; k <= 20; ++k) {
    const Bgr c = speed_colour_bgr(k / 20.0);
    const int sum = c[0] + c[1] + c[2];
    EXPECT_GT(sum, last) << k;
    last = sum;
  }
}

TEST(SpeedImage, SpheresLandWhereTheyAreInTheirSpeedsColour) {
  SpeedImageOptions o = options(256, 2.0);
  Scene s;
  s.add(0.05, 0.0, 0.0, 0.01, 0.0);   // right of the axis, at rest
  s.add(0.0, 0.05, 0.0, 0.01, 1.0);   // above the axis, half the scale
  s.add(-0.05, 0.0, 0.0, 0.01, 9.0);  // left of the axis, above the scale
  s.add(std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0, 0.01, 1.0);  // skipped, not drawn
  const cv::Mat img = s.render(o);
  const auto g = speed_image_geometry(0.1, o);
  ASSERT_EQ(img.cols, g.width);
  ASSERT_EQ(img.rows, g.height);
  ASSERT_EQ(img.type(), CV_8UC3);
  EXPECT_NEAR(g.px_per_m, 0.5 * 0.92 * 256 / 0.1, 1e-9);
  EXPECT_EQ(pixel(img, g.centre_col + 0.05 * g.px_per_m, g.centre_row), speed_colour_bgr(0.0));
  EXPECT_EQ(pixel(img, g.centre_col, g.centre_row - 0.05 * g.px_per_m), speed_colour_bgr(0.5));
  EXPECT_EQ(pixel(img, g.centre_col - 0.05 * g.px_per_m, g.centre_row), speed_colour_bgr(1.0));
  // the mirror images of those places are empty drum (light grey), the axis too; outside the drum white
  const Bgr inside{235, 235, 235}, outside{255, 255, 255};
  EXPECT_EQ(pixel(img, g.centre_col, g.centre_row + 0.05 * g.px_per_m), inside);
  EXPECT_EQ(pixel(img, g.centre_col, g.centre_row), inside);
  EXPECT_EQ(pixel(img, 2.0, g.height - 2.0), outside);  // the drum square's lower left corner
  // a sphere's edge: 0.6 of its radius from its centre still its colour, 1.6 radii away not
  EXPECT_EQ(pixel(img, g.centre_col + 0.056 * g.px_per_m, g.centre_row), speed_colour_bgr(0.0));
  EXPECT_EQ(pixel(img, g.centre_col + 0.066 * g.px_per_m, g.centre_row), inside);
}

TEST(SpeedImage, TheNearerOfTwoOverlappingSpheresIsSeenWhateverTheOrder) {
  SpeedImageOptions o = options(200, 1.0);
  const auto g = speed_image_geometry(0.1, o);
  for (int order = 0; order < 2; ++order) {
    Scene s;
    if (order == 0) {
      s.add(-0.03, -0.04, 0.002, 0.008, 0.25);  // nearer to the viewer at +z
      s.add(-0.03, -0.04, -0.002, 0.014, 0.75);
    } else {
      s.add(-0.03, -0.04, -0.002, 0.014, 0.75);
      s.add(-0.03, -0.04, 0.002, 0.008, 0.25);
    }
    const cv::Mat img = s.render(o);
    EXPECT_EQ(pixel(img, g.centre_col - 0.03 * g.px_per_m, g.centre_row + 0.04 * g.px_per_m), speed_colour_bgr(0.25))
        << "order " << order;
    // the farther, larger sphere shows around the nearer one (11 mm from the centres: 3 mm
    // beyond the nearer one's edge, 3 mm within the farther one's)
    EXPECT_EQ(pixel(img, g.centre_col - 0.03 * g.px_per_m + 0.011 * g.px_per_m, g.centre_row + 0.04 * g.px_per_m),
              speed_colour_bgr(0.75))
        << "order " << order;
  }
}

TEST(SpeedImage, ColourBarRunsFromZeroAtTheBottomToTheTopOfTheScale) {
  SpeedImageOptions o = options(300, 0.0105);
  const cv::Mat img = Scene{}.render(o);
  const auto g = speed_image_geometry(0.1, o);
  const double mid_col = 0.5 * (g.bar_col0 + g.bar_col1);
  EXPECT_EQ(pixel(img, mid_col, g.bar_row_bottom), speed_colour_bgr(0.0));
  EXPECT_EQ(pixel(img, mid_col, g.bar_row_top), speed_colour_bgr(1.0));
  const int mid_row = (g.bar_row_top + g.bar_row_bottom) / 2;
  EXPECT_EQ(pixel(img, mid_col, mid_row),
            speed_colour_bgr(static_cast<double>(g.bar_row_bottom - mid_row) / (g.bar_row_bottom - g.bar_row_top)));
  EXPECT_GT(g.bar_col0, 300);  // right of the drum's square
  EXPECT_LT(g.bar_col1, g.width);
}

TEST(SpeedImage, PeriodicDepthIsTakenWithinOnePeriod) {
  // Two spheres at the same place: A at z = 4 mm, B at z = 6.5 mm, which in a drum of width 5 mm
  // with a periodic axis is z = 1.5 mm, behind A. Without the period B would be drawn on top.
  SpeedImageOptions o = options(200, 1.0);
  const auto g = speed_image_geometry(0.1, o);
  Scene s;
  s.add(0.02, -0.05, 0.004, 0.01, 0.25);
  s.add(0.02, -0.05, 0.0065, 0.01, 0.75);
  const double col = g.centre_col + 0.02 * g.px_per_m, row = g.centre_row + 0.05 * g.px_per_m;
  EXPECT_EQ(pixel(s.render(o), col, row), speed_colour_bgr(0.75));
  o.period_z_m = 0.005;
  EXPECT_EQ(pixel(s.render(o), col, row), speed_colour_bgr(0.25));
  // below zero too: -1 mm is 4 mm, in front of 1.5 mm
  s.z = {0.0015, -0.001};
  EXPECT_EQ(pixel(s.render(o), col, row), speed_colour_bgr(0.75));
}

TEST(SpeedImage, NonFiniteSpheresAreLeftOutWithoutDisturbingTheOrder) {
  SpeedImageOptions o = options(200, 1.0);
  const auto g = speed_image_geometry(0.1, o);
  Scene s;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int k = 0; k < 40; ++k) {  // NaN depths mixed in among spheres of one place
    s.add(-0.02, 0.03, k % 3 == 0 ? nan : 0.0001 * k, 0.01, k % 3 == 0 ? 0.0 : 0.01 * k);
    s.add(0.05, 0.0, 0.0, 0.01, k == 7 ? nan : 0.5);  // a NaN speed: not drawn
  }
  const cv::Mat img = s.render(o);
  // the nearest finite one (k = 38, z = 3.8 mm) on top
  EXPECT_EQ(pixel(img, g.centre_col - 0.02 * g.px_per_m, g.centre_row - 0.03 * g.px_per_m), speed_colour_bgr(0.01 * 38));
  EXPECT_EQ(pixel(img, g.centre_col + 0.05 * g.px_per_m, g.centre_row), speed_colour_bgr(0.5));
}

TEST(SpeedImage, BarHasATriangleForTheSpeedsAboveTheScale) {
  SpeedImageOptions o = options(256, 0.2);
  const cv::Mat img = Scene{}.render(o);
  const auto g = speed_image_geometry(0.1, o);
  const double mid_col = 0.5 * (g.bar_col0 + g.bar_col1);
  EXPECT_EQ(pixel(img, mid_col, g.bar_row_top - 6), speed_colour_bgr(1.0));
  EXPECT_EQ(pixel(img, mid_col, g.bar_row_top - 20), (Bgr{255, 255, 255}));
}

TEST(SpeedImage, BadArgumentsAreRefused) {
  Scene s;
  s.add(0.0, 0.0, 0.0, 0.01, 0.1);
  SpeedImageOptions o;
  EXPECT_THROW(render_speed_image(s.x, s.y, s.z, s.r, std::vector<double>{}, 0.1, o), std::invalid_argument);
  EXPECT_THROW(s.render(o, 0.0), std::invalid_argument);
  o.max_speed_m_s = 0.0;
  EXPECT_THROW(s.render(o), std::invalid_argument);
  o.max_speed_m_s = 1.0;
  o.drum_px = 32;
  EXPECT_THROW(s.render(o), std::invalid_argument);
}
