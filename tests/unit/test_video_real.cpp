// The video path on frames that look like real back-lit recordings (issue 12): vignetting, camera
// noise, JPEG blocking, dust on the end plates, a drum off the image centre in a non-square image;
// a video file read by OpenCV's VideoCapture; and the messages on bad video input.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "analysis/backlit_image.hpp"
#include "test_analysis_helpers.hpp"

using namespace biodem;
using namespace biodem::analysis;
namespace fs = std::filesystem;

namespace {

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// A camera frame: width x height, drum disc of radius R at (cx, cy), back-light 230 at the disc
// centre falling by 40 % towards the rim (quadratic vignetting about the image centre... here the
// disc centre), background 40, powder transmitting 9 % of the light, Gaussian noise, dust specks.
struct Camera {
  int width = 720, height = 540;
  double cx = 391.3, cy = 258.6, radius = 230.0;
  double light = 230.0, vignette = 0.40, noise_sigma = 6.0;
  double powder = 0.09;  // the part of the light the bed passes
  bool dust = true;
};

// Drawn bed: disc pixels below the line y_up = c + tan(theta) x (drum-centred, pixels).
cv::Mat bed_mask(const Camera& c, double theta_deg, double height_px) {
  cv::Mat m(c.height, c.width, CV_8UC1, cv::Scalar(0));
  const double t = std::tan(theta_deg * std::numbers::pi / 180.0);
  for (int i = 0; i < m.rows; ++i)
    for (int j = 0; j < m.cols; ++j) {
      const double x = j - c.cx, y = c.cy - i;
      if (std::hypot(x, y) <= c.radius && y <= height_px + t * x) m.at<std::uint8_t>(i, j) = 255;
    }
  return m;
}

// Back-lit grey image of a bed (empty mask: the empty drum, for --background).
cv::Mat camera_frame(const Camera& c, const cv::Mat& bed, std::uint64_t seed) {
  test::Noise rng(seed);
  cv::Mat img(c.height, c.width, CV_8UC1);
  for (int i = 0; i < img.rows; ++i)
    for (int j = 0; j < img.cols; ++j) {
      const double rr = std::hypot(j - c.cx, i - c.cy) / c.radius;
      double v = 40.0;
      if (rr <= 1.0) {
        const double lit = c.light * (1.0 - c.vignette * rr * rr);
        v = bed.at<std::uint8_t>(i, j) ? c.powder * lit : lit;
      }
      v += rng.gaussian(c.noise_sigma);
      img.at<std::uint8_t>(i, j) = cv::saturate_cast<std::uint8_t>(v);
    }
  if (c.dust) {
    // Dust on the end plates: dark specks of 2 to 6 px radius in the lit part of the disc.
    const std::vector<cv::Point2d> at{{-120, 150}, {60, 170}, {150, 60}, {-40, 90}, {175, -20}};
    int r = 2;
    for (const auto& p : at) {
      cv::circle(img, cv::Point(static_cast<int>(c.cx + p.x), static_cast<int>(c.cy - p.y)), r, cv::Scalar(25),
                 cv::FILLED, cv::LINE_AA);
      r = r % 6 + 1;
    }
  }
  return img;
}

// A 320 x 240 frame with the drum off-centre (radius 105 px): the films of the CLI tests.
Camera small_camera() {
  Camera c;
  c.width = 320;
  c.height = 240;
  c.cx = 170.4;
  c.cy = 118.2;
  c.radius = 105.0;
  return c;
}

cv::Mat jpeg(const cv::Mat& img, int quality) {
  std::vector<std::uint8_t> buf;
  cv::imencode(".jpg", img, buf, {cv::IMWRITE_JPEG_QUALITY, quality});
  return cv::imdecode(buf, cv::IMREAD_GRAYSCALE);
}

}  // namespace

// Vignetting (light falling 40 % towards the rim), Gaussian noise (sigma 6 grey levels), JPEG at
// quality 70 and five dust specks, drum off-centre in a 720 x 540 image. Tolerances (issue 12):
// alpha within 0.5 deg of the drawn bed's centroid angle (and of 90 deg + tilt), surface angle
// within 0.5 deg, r^2 of the flat bed above 0.995 (measured: alpha within 0.012 deg, r^2 >=
// 0.99996); with the per-frame fitted back-light and with
// an empty-drum background.
TEST(VideoRealFrames, VignettedNoisyJpegFramesWithDust) {
  Camera c;
  const cv::Mat empty_drum = jpeg(camera_frame(c, cv::Mat::zeros(c.height, c.width, CV_8UC1), 99), 70);
  const DrumDisc disc = find_drum_disc(empty_drum);
  EXPECT_NEAR(disc.cx_px, c.cx, 1.0);
  EXPECT_NEAR(disc.cy_px, c.cy, 1.0);
  EXPECT_NEAR(disc.radius_px, c.radius, 1.5);  // the dimmed rim shifts the blurred edge ~1 px in
  double worst_alpha = 0.0, worst_r2 = 1.0;
  for (double theta : {22.0, 30.0, 38.0}) {
    const cv::Mat bed = bed_mask(c, theta, -45.0);
    const double drawn = test::mask_alpha_deg(bed, c.cx, c.cy);
    EXPECT_NEAR(drawn, 90.0 + theta, 0.3);
    const cv::Mat img = jpeg(camera_frame(c, bed, 7 + static_cast<std::uint64_t>(theta)), 70);
    const DrumDisc d = find_drum_disc(img);
    EXPECT_NEAR(d.radius_px, c.radius, 1.5) << "tilt " << theta;
    for (int with_background = 0; with_background < 2; ++with_background) {
      FrameParams p;
      if (with_background) p.illumination = background_illumination(empty_drum, disc);
      const FrameMeasure m = measure_backlit_frame(img, with_background ? disc : d, p);
      ASSERT_TRUE(m.has_powder);
      EXPECT_NEAR(m.alpha_deg, drawn, 0.5) << "tilt " << theta << " background " << with_background;
      // Tighter: the bed alone counts. Thresholding every dark pixel of the disc (the method
      // before issue 12) is off by 0.07 to 0.15 deg on these frames (dust and noise pixels).
      EXPECT_NEAR(m.alpha_deg, drawn, 0.05) << "tilt " << theta << " background " << with_background;
      ASSERT_TRUE(m.surface.valid);
      EXPECT_NEAR(m.surface.angle_deg, theta, 0.5) << "tilt " << theta;
      EXPECT_GT(m.surface.r2, 0.995) << "tilt " << theta << " background " << with_background;
      worst_alpha = std::max(worst_alpha, std::abs(m.alpha_deg - drawn));
      worst_r2 = std::min(worst_r2, m.surface.r2);
    }
  }
  std::printf("[measured] worst |alpha - drawn| = %.3f deg, lowest r^2 = %.5f\n", worst_alpha, worst_r2);
}

// The same kind of frames with a strong side-to-side light
// gradient (230 on the left, 95 on the right, the powder still passing 9 %) are thresholded by
// the corrected image; an empty drum under that gradient shows no powder.
TEST(VideoRealFrames, UnevenBackLightAndEmptyDrum) {
  Camera c;
  c.vignette = 0.0;
  auto gradient = [&](const cv::Mat& bed, std::uint64_t seed) {
    cv::Mat img = camera_frame(c, bed, seed);
    for (int i = 0; i < img.rows; ++i)
      for (int j = 0; j < img.cols; ++j) {
        const double rr = std::hypot(j - c.cx, i - c.cy);
        if (rr <= c.radius) {
          const double f = 1.0 - 0.3 * (j - c.cx + c.radius) / c.radius;  // 1 ... 0.4
          img.at<std::uint8_t>(i, j) = cv::saturate_cast<std::uint8_t>(img.at<std::uint8_t>(i, j) * f);
        }
      }
    return img;
  };
  const cv::Mat bed = bed_mask(c, 33.0, -30.0);
  const cv::Mat img = gradient(bed, 3);
  const DrumDisc d = find_drum_disc(img);
  const FrameMeasure m = measure_backlit_frame(img, d, FrameParams{});
  EXPECT_NEAR(m.alpha_deg, test::mask_alpha_deg(bed, c.cx, c.cy), 0.5);
  EXPECT_GT(m.surface.r2, 0.995);
  const cv::Mat empty = gradient(cv::Mat::zeros(c.height, c.width, CV_8UC1), 4);
  const FrameMeasure e = measure_backlit_frame(empty, find_drum_disc(empty), FrameParams{});
  EXPECT_FALSE(e.has_powder) << e.powder_px << " px";
}

// A grey bed (passing 30 % or 45 % of the light instead of 9 %) under the 40 % vignetting: the
// back-light fitted to the frame itself (estimate_illumination) must follow the lit disc under
// the bed, not the bed: Otsu's split of the disc's samples picks the lit ones. Tolerance: the
// fitted light within 3 % of the drawn light at every pixel under the bed (inside 97 % of the
// radius), alpha within 0.05 deg of the drawn bed. It fails with the first fit over every sample
// instead of Otsu's lit ones (84-99 % off under the bed, checked); without the refit on the
// samples above 70 % of the first fit it still passes (0.93 %: these frames leave no grey lit
// sample for the refit to drop). Beds passing over half the light are beyond this fit
// (docs/analysis.md).
TEST(VideoRealFrames, GreyBedFittedBackLightFollowsTheLitDisc) {
  Camera c;
  c.dust = false;
  const cv::Mat bed = bed_mask(c, 30.0, -40.0);
  const double drawn = test::mask_alpha_deg(bed, c.cx, c.cy);
  for (const double powder : {0.30, 0.45}) {
    c.powder = powder;
    const cv::Mat img = camera_frame(c, bed, 21);
    const DrumDisc d = find_drum_disc(img);
    const cv::Mat light = estimate_illumination(img, d);
    double worst = 0.0;
    std::size_t under = 0;
    for (int i = 0; i < img.rows; ++i)
      for (int j = 0; j < img.cols; ++j) {
        const double rr = std::hypot(j - c.cx, i - c.cy) / c.radius;
        if (rr > 0.97 || !bed.at<std::uint8_t>(i, j)) continue;
        const double truth = c.light * (1.0 - c.vignette * rr * rr);
        worst = std::max(worst, std::abs(light.at<float>(i, j) / truth - 1.0));
        ++under;
      }
    const FrameMeasure m = measure_backlit_frame(img, d, FrameParams{});
    std::printf("[measured] bed passing %.0f %% of the light: fitted back-light under the bed within %.2f %% of the "
                "drawn one (%zu px), alpha %.3f deg against %.3f drawn\n",
                100.0 * powder, 100.0 * worst, under, m.alpha_deg, drawn);
    EXPECT_GT(under, 10000u);
    EXPECT_LT(worst, 0.03) << "bed passing " << powder;
    ASSERT_TRUE(m.has_powder) << "bed passing " << powder;
    EXPECT_NEAR(m.alpha_deg, drawn, 0.05) << "bed passing " << powder;
    EXPECT_NEAR(m.bed_light, powder, 0.02) << "bed passing " << powder;  // (measured: FrameMeasure::bed_light)
  }
}

// A bed passing over half the light, without --background: `biodem video` measures the frames
// and says on stderr that the bed passes that part of the light and that --background is needed
// (the per-frame back-light fit cannot tell such a bed from the vignetting: docs/analysis.md);
// not for a bed passing 45 %, nor with --background. The bed's measured part of the light
// (FrameMeasure::bed_light) is near the drawn one at 9 % and 45 %, and above it at 55 % (the fit
// pulled towards the bed makes the bed look brighter). It fails with the
// warning's limit at 0.4 or 0.8 instead of 0.5, and when the warning is given with --background
// too (checked).
TEST(VideoRealFrames, GreyBedWithoutBackgroundIsWarnedAbout) {
  test::TempDir dir("grey_bed");
  Camera c = small_camera();
  c.dust = false;
  const cv::Mat bed = bed_mask(c, 30.0, -20.0);
  cv::imwrite((dir / "empty.png").string(), camera_frame(c, cv::Mat::zeros(c.height, c.width, CV_8UC1), 5));
  for (const double powder : {0.09, 0.45, 0.55}) {
    c.powder = powder;
    const std::string tag = std::to_string(static_cast<int>(std::lround(100 * powder)));
    const fs::path frames = dir / ("frames_" + tag);
    fs::create_directories(frames);
    for (int k = 0; k < 4; ++k) {
      char name[16];
      std::snprintf(name, sizeof name, "f%d.png", k);
      ASSERT_TRUE(cv::imwrite((frames / name).string(), camera_frame(c, bed, 40 + static_cast<std::uint64_t>(k))));
    }
    const cv::Mat one = camera_frame(c, bed, 40);
    const FrameMeasure m = measure_backlit_frame(one, find_drum_disc(one), FrameParams{});
    std::printf("[measured] bed passing %.0f %% of the light: FrameMeasure::bed_light %.3f\n", 100 * powder, m.bed_light);
    if (powder < 0.5) {
      EXPECT_NEAR(m.bed_light, powder, 0.05) << "bed passing " << powder;
    } else {  // the first fit, pulled down by the bed, makes it look brighter still
      EXPECT_GT(m.bed_light, 0.5) << "bed passing " << powder;
    }
    const auto v = test::run_biodem("video " + test::quote(frames) + " --fps 25 --rpm 1 --quiet --out " +
                                    test::quote(dir / ("v" + tag)));
    ASSERT_EQ(v.status, 0) << v.output;
    const bool warned = contains(v.output, "warning: the bed looks ") && contains(v.output, "give --background");
    EXPECT_EQ(warned, powder > 0.5) << "bed passing " << powder << ": " << v.output;
    if (powder > 0.5) {
      const auto b = test::run_biodem("video " + test::quote(frames) + " --fps 25 --rpm 1 --quiet --background " +
                                      test::quote(dir / "empty.png") + " --out " + test::quote(dir / ("b" + tag)));
      ASSERT_EQ(b.status, 0) << b.output;
      EXPECT_FALSE(contains(b.output, "warning: the bed looks")) << b.output;
    }
  }
}

// A synthetic film written with OpenCV (MJPG in .avi, available in Debian's OpenCV) gives the
// same series.csv as the folder of its decoded frames (bit for bit: both go through the same grey
// conversion), and alpha within 1 deg of the drawn beds (MJPG is lossy). Also --background on the
// command line, and its errors.
TEST(VideoRealFrames, VideoFileGivesTheSameSeriesAsItsFrames) {
  test::TempDir dir("video_file");
  Camera c = small_camera();
  const fs::path avi = dir / "film.avi", decoded = dir / "decoded";
  std::vector<double> drawn;
  {
    cv::VideoWriter w(avi.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 25.0,
                      cv::Size(c.width, c.height), false);
    if (!w.isOpened()) GTEST_SKIP() << "this OpenCV build cannot write MJPG .avi (no video writer)";
    double tilt = 20.0;
    for (int k = 0; k < 40; ++k) {
      tilt += (k % 13 == 12) ? -6.0 : 0.5;
      const cv::Mat bed = bed_mask(c, tilt, -20.0);
      drawn.push_back(test::mask_alpha_deg(bed, c.cx, c.cy));
      w.write(camera_frame(c, bed, 100 + static_cast<std::uint64_t>(k)));
    }
  }
  fs::create_directories(decoded);
  {
    cv::VideoCapture cap(avi.string());
    ASSERT_TRUE(cap.isOpened());
    cv::Mat f;
    for (int k = 0; cap.read(f); ++k) {
      char name[32];
      std::snprintf(name, sizeof name, "f%04d.png", k);
      ASSERT_TRUE(cv::imwrite((decoded / name).string(), f));
    }
  }
  cv::imwrite((dir / "empty.png").string(), camera_frame(c, cv::Mat::zeros(c.height, c.width, CV_8UC1), 5));

  const auto v = test::run_biodem("video " + test::quote(avi) + " --fps 25 --rpm 1 --quiet --out " + test::quote(dir / "v"));
  ASSERT_EQ(v.status, 0) << v.output;
  const auto f = test::run_biodem("video " + test::quote(decoded) + " --fps 25 --rpm 1 --quiet --out " + test::quote(dir / "f"));
  ASSERT_EQ(f.status, 0) << f.output;
  const std::string from_video = test::read_text(dir / "v" / "series.csv");
  EXPECT_EQ(from_video, test::read_text(dir / "f" / "series.csv"));
  const auto rows = test::read_lines(dir / "v" / "series.csv");
  ASSERT_EQ(rows.size(), 1 + drawn.size());
  double worst = 0.0;
  for (std::size_t k = 0; k < drawn.size(); ++k) {
    const auto cells = test::split_csv(rows[k + 1]);
    EXPECT_NEAR(std::stod(cells[0]), static_cast<double>(k) / 25.0, 1e-9);
    const double a = std::stod(cells[2]);
    EXPECT_NEAR(a, drawn[k], 1.0) << "frame " << k;
    worst = std::max(worst, std::abs(a - drawn[k]));
  }
  std::printf("[measured] video = frames folder byte for byte; worst |alpha - drawn| = %.3f deg (MJPG)\n", worst);

  const auto b = test::run_biodem("video " + test::quote(avi) + " --fps 25 --rpm 1 --quiet --background " +
                                  test::quote(dir / "empty.png") + " --out " + test::quote(dir / "b"));
  ASSERT_EQ(b.status, 0) << b.output;
  const auto brows = test::read_lines(dir / "b" / "series.csv");
  ASSERT_EQ(brows.size(), rows.size());
  for (std::size_t k = 0; k < drawn.size(); ++k)
    EXPECT_NEAR(std::stod(test::split_csv(brows[k + 1])[2]), drawn[k], 1.0) << "frame " << k;

  // --fps other than the container's 25 fps: times follow --fps, with a warning.
  const auto w30 = test::run_biodem("video " + test::quote(avi) + " --fps 30 --rpm 1 --quiet --out " + test::quote(dir / "w30"));
  ASSERT_EQ(w30.status, 0) << w30.output;
  EXPECT_TRUE(contains(w30.output, "differs from the video's own frame rate 25 fps")) << w30.output;
  EXPECT_NEAR(std::stod(test::split_csv(test::read_lines(dir / "w30" / "series.csv")[2])[0]), 1.0 / 30.0, 1e-9);

  // Bad input: one line naming the file or option, exit status 2, nothing computed.
  { std::ofstream(dir / "junk.avi") << "not a video"; }
  auto e = test::run_biodem("video " + test::quote(dir / "junk.avi") + " --fps 25 --rpm 1 --out " + test::quote(dir / "e1"));
  EXPECT_EQ(e.status, 2) << e.output;
  EXPECT_TRUE(contains(e.output, "cannot open video")) << e.output;
  EXPECT_FALSE(fs::exists(dir / "e1" / "series.csv"));
  e = test::run_biodem("video " + test::quote(avi) + " --fps -3 --rpm 1 --out " + test::quote(dir / "e2"));
  EXPECT_EQ(e.status, 2);
  EXPECT_TRUE(contains(e.output, "--fps must be > 0")) << e.output;
  e = test::run_biodem("video " + test::quote(avi) + " --fps 25 --rpm 1 --background " +
                       test::quote(dir / "nothere.png") + " --out " + test::quote(dir / "e3"));
  EXPECT_EQ(e.status, 2);
  EXPECT_TRUE(contains(e.output, "--background")) << e.output;
  EXPECT_TRUE(contains(e.output, "nothere.png")) << e.output;
  cv::imwrite((dir / "small.png").string(), cv::Mat(100, 100, CV_8UC1, cv::Scalar(200)));
  e = test::run_biodem("video " + test::quote(avi) + " --fps 25 --rpm 1 --center-px 170 118 --radius-px 105 --background " +
                       test::quote(dir / "small.png") + " --out " + test::quote(dir / "e4"));
  EXPECT_EQ(e.status, 2);
  EXPECT_TRUE(contains(e.output, "small.png")) << e.output;
  EXPECT_FALSE(fs::exists(dir / "e4" / "series.csv"));
  { std::ofstream(dir / "bad.png") << "not a png"; }
  e = test::run_biodem("video " + test::quote(avi) + " --fps 25 --rpm 1 --background " + test::quote(dir / "bad.png") +
                       " --out " + test::quote(dir / "e5"));
  EXPECT_EQ(e.status, 2);
  EXPECT_TRUE(contains(e.output, "cannot be read")) << e.output;
}

// Constant memory: frames are read and measured in batches and their rows written as they go,
// so a film of 1,200 frames takes no more memory than one of 100 (a 240 x 180 grey frame is
// 43 kB: holding 1,200 of them would add ~52 MB). Tolerance: peak RSS grows by less than 15 MB.
TEST(VideoRealFrames, MemoryDoesNotGrowWithTheNumberOfFrames) {
  test::TempDir dir("video_memory");
  Camera c;
  c.width = 240;
  c.height = 180;
  c.cx = 121.0;
  c.cy = 90.0;
  c.radius = 80.0;
  c.dust = false;
  auto film = [&](const fs::path& path, int frames) {
    cv::VideoWriter w(path.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 50.0,
                      cv::Size(c.width, c.height), false);
    if (!w.isOpened()) return false;
    std::vector<cv::Mat> looks;
    for (int k = 0; k < 10; ++k) looks.push_back(camera_frame(c, bed_mask(c, 20.0 + k, -15.0), 7 + static_cast<std::uint64_t>(k)));
    for (int k = 0; k < frames; ++k) w.write(looks[static_cast<std::size_t>(k % 10)]);
    return true;
  };
  if (!film(dir / "short.avi", 100)) GTEST_SKIP() << "this OpenCV build cannot write MJPG .avi";
  ASSERT_TRUE(film(dir / "long.avi", 1200));
  auto peak_rss_kb = [] {
    rusage u{};
    getrusage(RUSAGE_CHILDREN, &u);
    return static_cast<double>(u.ru_maxrss);
  };
  const auto a = test::run_biodem("video " + test::quote(dir / "short.avi") + " --fps 50 --rpm 1 --quiet --out " + test::quote(dir / "a"));
  ASSERT_EQ(a.status, 0) << a.output;
  const double short_kb = peak_rss_kb();
  const auto b = test::run_biodem("video " + test::quote(dir / "long.avi") + " --fps 50 --rpm 1 --quiet --out " + test::quote(dir / "b"));
  ASSERT_EQ(b.status, 0) << b.output;
  const double long_kb = peak_rss_kb();
  EXPECT_EQ(test::read_lines(dir / "b" / "series.csv").size(), 1201u);
  EXPECT_LT(long_kb - short_kb, 15.0 * 1024.0) << "peak RSS " << short_kb << " kB for 100 frames, " << long_kb << " kB for 1200";
  std::printf("[measured] peak RSS %.1f MB for 100 frames, %.1f MB for 1200 frames\n", short_kb / 1024.0, long_kb / 1024.0);
}
