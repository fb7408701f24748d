// biodem::output::write_png (libpng's simplified API) against OpenCV's decoder: every pixel of a grey and
// a BGR image comes back, including images whose rows are padded (a region of a larger image).
#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "core/error.hpp"
#include "output/plot_writer.hpp"
#include "output/png_mat.hpp"

namespace {
namespace fs = std::filesystem;

fs::path scratch(const char* name) {
  const fs::path d = fs::temp_directory_path() / "biodem_png_test";
  fs::create_directories(d);
  return d / name;
}

cv::Mat pattern(int rows, int cols, int type) {
  cv::Mat m(rows, cols, type);
  cv::randu(m, cv::Scalar::all(0), cv::Scalar::all(256));
  return m;
}

double max_difference(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return 1e9;
  return cv::norm(a, b, cv::NORM_INF);
}
}  // namespace

TEST(PngFile, GreyImageComesBackPixelForPixel) {
  cv::theRNG().state = 7;
  const cv::Mat grey = pattern(37, 53, CV_8UC1);
  const fs::path p = scratch("grey.png");
  biodem::output::write_png(p.string(), grey);
  const cv::Mat back = cv::imread(p.string(), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(back.empty());
  EXPECT_EQ(back.type(), CV_8UC1);
  EXPECT_EQ(max_difference(grey, back), 0.0);
}

TEST(PngFile, BgrImageComesBackWithItsChannelsInOrder) {
  cv::theRNG().state = 11;
  const cv::Mat bgr = pattern(29, 41, CV_8UC3);
  const fs::path p = scratch("bgr.png");
  biodem::output::write_png(p.string(), bgr);
  const cv::Mat back = cv::imread(p.string(), cv::IMREAD_UNCHANGED);  // OpenCV decodes to BGR
  ASSERT_FALSE(back.empty());
  EXPECT_EQ(back.type(), CV_8UC3);
  EXPECT_EQ(max_difference(bgr, back), 0.0);
  // One pure blue pixel stays blue (a swapped red and blue would fail here).
  cv::Mat blue(2, 2, CV_8UC3, cv::Scalar(255, 0, 0));
  biodem::output::write_png(p.string(), blue);
  const cv::Vec3b px = cv::imread(p.string(), cv::IMREAD_COLOR).at<cv::Vec3b>(1, 1);
  EXPECT_EQ(px[0], 255);
  EXPECT_EQ(px[2], 0);
}

TEST(PngFile, RowsOfARegionOfALargerImage) {
  cv::theRNG().state = 3;
  const cv::Mat big = pattern(60, 80, CV_8UC3);
  const cv::Mat roi = big(cv::Rect(5, 7, 33, 21));  // rows 80*3 bytes apart, 33*3 used
  ASSERT_FALSE(roi.isContinuous());
  const fs::path p = scratch("roi.png");
  biodem::output::write_png(p.string(), roi);
  EXPECT_EQ(max_difference(roi.clone(), cv::imread(p.string(), cv::IMREAD_UNCHANGED)), 0.0);
}

TEST(PngFile, RefusesWhatItCannotWriteWithThePath) {
  const cv::Mat f32(4, 4, CV_32FC1, cv::Scalar(0.5));
  try {
    biodem::output::write_png("/tmp/x.png", f32);
    FAIL() << "a float image was written";
  } catch (const biodem::Error& e) {
    EXPECT_NE(std::string(e.what()).find("/tmp/x.png"), std::string::npos) << e.what();
  }
  const cv::Mat grey(4, 4, CV_8UC1, cv::Scalar(9));
  EXPECT_THROW(biodem::output::write_png("/nonexistent_dir_biodem/x.png", grey), biodem::Error);
}

// The automatic legend goes to the corner with the fewest data points: a series rising to the
// top right (alpha before an avalanche) puts it top left; one falling from the top left, top
// right; one filling the top, at the bottom. A legend left at its default stays where it is.
TEST(PlotLegend, AutomaticCornerAvoidsTheData) {
  biodem::output::Plot p;
  p.legend = biodem::output::LegendPlace::automatic;
  biodem::output::PlotSeries rise{"alpha", {}, {}};
  for (int i = 0; i <= 200; ++i) {
    rise.x.push_back(i / 200.0);
    rise.y.push_back(30.0 + 10.0 * i / 200.0);
  }
  p.series = {rise};
  EXPECT_EQ(biodem::output::resolved_legend(p), biodem::output::LegendPlace::top_left);
  for (auto& y : p.series[0].y) y = 70.0 - y;  // falling from the top left
  EXPECT_EQ(biodem::output::resolved_legend(p), biodem::output::LegendPlace::top_right);
  biodem::output::PlotSeries top{"top", {}, {}};
  for (int i = 0; i <= 200; ++i) {
    top.x.push_back(i / 200.0);
    top.y.push_back(i % 2 ? 40.0 : 39.0);  // a band along the top; the floor set by the next point
  }
  top.x.push_back(0.5);
  top.y.push_back(0.0);
  p.series = {top};
  const auto place = biodem::output::resolved_legend(p);
  EXPECT_TRUE(place == biodem::output::LegendPlace::bottom_right || place == biodem::output::LegendPlace::bottom_left);
  p.legend = biodem::output::LegendPlace::top_right;
  EXPECT_EQ(biodem::output::resolved_legend(p), biodem::output::LegendPlace::top_right);
}
