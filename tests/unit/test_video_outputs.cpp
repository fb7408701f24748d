// `biodem video` and its output folder (SPEC 11, docs/analysis.md section 6): what it replaces,
// what it refuses, what a failed or cut-short film leaves, and its messages on bad options and
// undecodable videos (one line each). Driven through the built binary on synthetic back-lit frames.
#ifdef BIODEM_HAVE_OPENCV
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "output/output_dir.hpp"
#include "output/series_csv.hpp"
#include "test_analysis_helpers.hpp"

using namespace biodem;
namespace fs = std::filesystem;

namespace {

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

std::size_t count_of(const std::string& s, const std::string& part) {
  std::size_t n = 0;
  for (auto at = s.find(part); at != std::string::npos; at = s.find(part, at + 1)) ++n;
  return n;
}

// A 240 x 240 back-lit drum (radius 110 px) with a flat bed at `tilt` degrees, or empty.
test::DrumImage small_drum() {
  test::DrumImage d;
  d.size = 240;
  d.cx = d.cy = 120.0;
  d.radius = 110.0;
  return d;
}

cv::Mat bed_frame(double tilt) {
  const test::DrumImage d = small_drum();
  return test::backlit_image(d, test::drawn_bed(d, test::flat_surface(tilt, -25.0)));
}

cv::Mat empty_drum_frame() {
  const test::DrumImage d = small_drum();
  return test::backlit_image(d, cv::Mat::zeros(d.size, d.size, CV_8UC1));
}

// n frames named <prefix>NNN.png with tilts 20, 21, ... (or the empty drum).
void write_frames(const fs::path& dir, int n, const std::string& prefix = "f", bool empty = false) {
  fs::create_directories(dir);
  for (int k = 0; k < n; ++k) {
    char name[64];
    std::snprintf(name, sizeof name, "%s%03d.png", prefix.c_str(), k);
    ASSERT_TRUE(cv::imwrite((dir / name).string(), empty ? empty_drum_frame() : bed_frame(20.0 + k)));
  }
}

std::string video_cmd(const fs::path& frames, const fs::path& out, const std::string& extra = "") {
  return "video " + test::quote(frames) + " --fps 10 --rpm 1 --quiet --out " + test::quote(out) +
         (extra.empty() ? "" : " " + extra);
}

void write_text(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }

// An exit status 2 (4: an output that cannot be written) with exactly one line, biodem's error.
void expect_one_line_error(const test::CommandResult& r, const std::string& part, int status = 2) {
  EXPECT_EQ(r.status, status) << r.output;
  EXPECT_EQ(count_of(r.output, "\n"), 1u) << r.output;
  EXPECT_TRUE(r.output.starts_with("biodem: error: ")) << r.output;
  EXPECT_TRUE(contains(r.output, part)) << r.output;
}

}  // namespace

// Defect 1: a new series replaces the one an earlier `biodem analyze` described, so its tables
// and plots go (as a fresh `biodem run` removes them); files that are not analyze's stay.
TEST(VideoOutputs, RerunRemovesAnEarlierAnalysis) {
  test::TempDir dir("video_rerun_analysis");
  write_frames(dir / "frames", 6);
  const fs::path out = dir / "out";
  fs::create_directories(out);
  const std::vector<std::string> analysis{"events.csv",           "descriptors.csv",   "threshold_sweep.csv",
                                          "alpha_vs_revolution.png", "cdf_uas.svg", "r2_vs_time.png"};
  for (const auto& f : analysis) write_text(out / f, "from an earlier analyze\n");
  write_text(out / "notes.txt", "mine\n");
  const auto r = test::run_biodem(video_cmd(dir / "frames", out));
  ASSERT_EQ(r.status, 0) << r.output;
  for (const auto& f : analysis) EXPECT_FALSE(fs::exists(out / f)) << f;
  EXPECT_TRUE(fs::exists(out / "notes.txt"));
  EXPECT_EQ(test::read_lines(out / "series.csv").size(), 7u);
}

// Defect 1: a folder holding a simulation run's outputs is refused (its series.csv would be
// replaced), with one line naming the file that shows it, and nothing in it changes.
TEST(VideoOutputs, RefusesASimulationRunFolder) {
  test::TempDir dir("video_run_folder");
  write_frames(dir / "frames", 3);
  for (const std::string marker : {"run.log", "checkpoint.bin"}) {
    const fs::path out = dir / ("run_" + marker);
    fs::create_directories(out);
    write_text(out / marker, "x\n");
    write_text(out / "series.csv", "the run's series\n");
    const auto r = test::run_biodem(video_cmd(dir / "frames", out));
    expect_one_line_error(r, marker);
    EXPECT_TRUE(contains(r.output, "--out")) << r.output;
    EXPECT_EQ(test::read_text(out / "series.csv"), "the run's series\n");
    EXPECT_FALSE(fs::exists(out / "video_check.png"));
  }
}

// Defect 1: the output folder is locked for the command, as a run locks its own: a video into a
// folder another biodem holds is refused with one line.
TEST(VideoOutputs, HoldsTheOutputFolderLock) {
  test::TempDir dir("video_lock");
  write_frames(dir / "frames", 3);
  const fs::path out = dir / "out";
  fs::create_directories(out);
  write_text(out / "series.csv", "earlier\n");
  {
    const output::DirLock held = output::lock_output_dir(out.string());
    const auto r = test::run_biodem(video_cmd(dir / "frames", out));
    expect_one_line_error(r, "another biodem run is writing to this folder", 4);
    EXPECT_EQ(test::read_text(out / "series.csv"), "earlier\n");
  }
  const auto r = test::run_biodem(video_cmd(dir / "frames", out));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(test::read_lines(out / "series.csv").size(), 4u);
}

// Defect 2: a run that fails (here: no frame shows powder, found only after every frame was
// measured) leaves series.csv, video_check.png and an earlier analysis as they were, and no
// temporary file.
TEST(VideoOutputs, FailedRunKeepsTheEarlierFiles) {
  test::TempDir dir("video_failed_keeps");
  write_frames(dir / "frames", 5);
  write_frames(dir / "empty", 5, "e", true);
  const fs::path out = dir / "out";
  auto r = test::run_biodem(video_cmd(dir / "frames", out));
  ASSERT_EQ(r.status, 0) << r.output;
  const std::string series = test::read_text(out / "series.csv");
  const std::string check = test::read_text(out / "video_check.png");
  ASSERT_FALSE(check.empty());
  write_text(out / "events.csv", "analysis of that series\n");

  r = test::run_biodem(video_cmd(dir / "empty", out));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_TRUE(contains(r.output, "biodem: error: no frame in")) << r.output;
  EXPECT_TRUE(contains(r.output, "showed powder")) << r.output;
  EXPECT_EQ(test::read_text(out / "series.csv"), series);
  EXPECT_TRUE(test::read_text(out / "video_check.png") == check) << "video_check.png was replaced";
  EXPECT_TRUE(fs::exists(out / "events.csv"));
  for (const auto& e : fs::directory_iterator(out))
    EXPECT_FALSE(e.path().filename().string().ends_with(".tmp")) << e.path();
}

// Defect 2: the rows kept in memory and written whole are the rows output::SeriesWriter writes
// (same header, cells and digits): each row read back and written again by SeriesWriter gives
// the same file byte for byte.
TEST(VideoOutputs, SeriesRowsAreThoseOfTheSeriesWriter) {
  test::TempDir dir("video_row_format");
  write_frames(dir / "frames", 4);
  write_frames(dir / "frames", 1, "g", true);  // g000.png, sorted last: alpha and r^2 empty
  const auto r = test::run_biodem(video_cmd(dir / "frames", dir / "out"));
  ASSERT_EQ(r.status, 0) << r.output;
  const auto lines = test::read_lines(dir / "out" / "series.csv");
  ASSERT_EQ(lines.size(), 6u);
  {
    output::SeriesWriter w(dir / "again.csv", false);
    for (std::size_t k = 1; k < lines.size(); ++k) {
      const auto c = test::split_csv(lines[k]);
      ASSERT_EQ(c.size(), 8u) << lines[k];
      auto num = [](const std::string& s) { return s.empty() ? std::optional<double>() : std::stod(s); };
      output::SeriesRow row;
      row.time_s = std::stod(c[0]);
      row.revolution = std::stod(c[1]);
      row.alpha_deg = num(c[2]).value_or(std::numeric_limits<double>::quiet_NaN());
      row.surface_r2 = num(c[3]);
      row.surface_angle_deg = num(c[4]);
      EXPECT_EQ(c[5], "");
      EXPECT_EQ(c[6], "");
      EXPECT_EQ(c[7], "");
      w.write(row);
    }
  }
  EXPECT_EQ(test::read_text(dir / "out" / "series.csv"), test::read_text(dir / "again.csv"));
  EXPECT_EQ(test::split_csv(lines.back())[2], "");  // the empty drum: alpha left empty
}

// Defect 3: --out naming the frames folder (however spelt) is refused with one line: the next
// run would read video_check.png as a frame. Nothing is written there.
TEST(VideoOutputs, RefusesTheFramesFolderAsOut) {
  test::TempDir dir("video_out_is_frames");
  const fs::path frames = dir / "frames";
  write_frames(frames, 3);
  fs::create_directories(dir / "other");
  for (const fs::path& out : {frames, frames / ".", dir / "other" / ".." / "frames"}) {
    const auto r = test::run_biodem(video_cmd(frames, out));
    expect_one_line_error(r, "is the frames folder");
    EXPECT_FALSE(fs::exists(frames / "video_check.png"));
    EXPECT_FALSE(fs::exists(frames / "series.csv"));
  }
  // A folder inside the frames folder is another folder (its files are not frames).
  const auto r = test::run_biodem(video_cmd(frames, frames / "out"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(test::read_lines(frames / "out" / "series.csv").size(), 4u);
}

// Defect 4: a video cut short (its container still declares every frame) gives the frames that
// decode and a one-line warning naming the two counts, exit status 0.
TEST(VideoOutputs, CutShortVideoIsWarnedAbout) {
  test::TempDir dir("video_cut_short");
  const fs::path avi = dir / "film.avi", cut = dir / "cut.avi";
  constexpr int kFrames = 60;
  {
    cv::VideoWriter w(avi.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10.0, cv::Size(240, 240), false);
    if (!w.isOpened()) GTEST_SKIP() << "this OpenCV build cannot write MJPG .avi (no video writer)";
    for (int k = 0; k < kFrames; ++k) w.write(bed_frame(20.0 + k % 10));
  }
  auto r = test::run_biodem(video_cmd(avi, dir / "whole"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_FALSE(contains(r.output, "warning")) << r.output;
  EXPECT_EQ(test::read_lines(dir / "whole" / "series.csv").size(), 1u + kFrames);

  fs::copy_file(avi, cut);
  fs::resize_file(cut, fs::file_size(avi) / 2);
  r = test::run_biodem(video_cmd(cut, dir / "cut"));
  ASSERT_EQ(r.status, 0) << r.output;
  const auto rows = test::read_lines(dir / "cut" / "series.csv");
  ASSERT_GT(rows.size(), 1u);
  ASSERT_LT(rows.size(), 1u + kFrames);
  const std::size_t decoded = rows.size() - 1;
  EXPECT_TRUE(contains(r.output, "warning: the video '" + cut.string() + "' declares " + std::to_string(kFrames) +
                                     " frames but only " + std::to_string(decoded) + " could be decoded"))
      << r.output;
  EXPECT_EQ(count_of(r.output, "\n"), 2u) << r.output;  // the warning and "wrote ..."
  std::printf("[measured] %d-frame MJPG film cut to half its bytes: %zu frames decoded\n", kFrames, decoded);
}

// Defect 5: unreadable files before the first good frame do not end the disc search (it counts
// readable frames only): 70 junk files, then good frames.
TEST(VideoOutputs, UnreadableFilesDoNotEndTheDiscSearch) {
  test::TempDir dir("video_junk_first");
  const fs::path frames = dir / "frames";
  fs::create_directories(frames);
  for (int k = 0; k < 70; ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "a%03d.png", k);
    write_text(frames / name, "not a png");
  }
  write_frames(frames, 4, "b");
  const auto r = test::run_biodem(video_cmd(frames, dir / "out"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "warning: skipped 70 unreadable frame(s): a000.png")) << r.output;
  const auto rows = test::read_lines(dir / "out" / "series.csv");
  ASSERT_EQ(rows.size(), 5u);
  EXPECT_NEAR(std::stod(test::split_csv(rows[1])[0]), 7.0, 1e-12);  // b000.png is frame 70: 7 s at 10 fps
}

// Defect 6: a negative --wall-zone-px (once taken silently as the default) and a --bin-px below 1
// are refused with one line naming the option.
TEST(VideoOutputs, NegativeWallZoneAndBinWidthAreRefused) {
  test::TempDir dir("video_bad_bins");
  write_frames(dir / "frames", 2);
  auto r = test::run_biodem(video_cmd(dir / "frames", dir / "o1", "--wall-zone-px -2"));
  expect_one_line_error(r, "--wall-zone-px must be >= 0");
  EXPECT_FALSE(fs::exists(dir / "o1" / "series.csv"));
  r = test::run_biodem(video_cmd(dir / "frames", dir / "o2", "--bin-px 0"));
  expect_one_line_error(r, "--bin-px must be >= 1");
  r = test::run_biodem(video_cmd(dir / "frames", dir / "o3", "--bin-px -4"));
  expect_one_line_error(r, "--bin-px must be >= 1");
  r = test::run_biodem(video_cmd(dir / "frames", dir / "o4", "--wall-zone-px 0"));
  EXPECT_EQ(r.status, 0) << r.output;
}

// Defect 6: bins so wide (or a wall zone so deep) that no frame has the 3 bins r^2 needs: one
// warning for the whole film, and surface_r2 empty in every row.
TEST(VideoOutputs, TooFewSurfaceBinsAreWarnedAboutOnce) {
  test::TempDir dir("video_few_bins");
  write_frames(dir / "frames", 5);
  const std::vector<std::pair<std::string, std::string>> settings{{"--bin-px 150", "wide_bins"},
                                                                   {"--wall-zone-px 200", "deep_wall_zone"}};
  for (const auto& [opt, folder] : settings) {
    const fs::path out = dir / folder;
    const auto r = test::run_biodem(video_cmd(dir / "frames", out, opt));
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_EQ(count_of(r.output, "r^2 needs 3"), 1u) << r.output;
    EXPECT_TRUE(contains(r.output, "surface_r2 is empty for every frame")) << r.output;
    const auto rows = test::read_lines(out / "series.csv");
    ASSERT_EQ(rows.size(), 6u);
    for (std::size_t k = 1; k < rows.size(); ++k) {
      EXPECT_NE(test::split_csv(rows[k])[2], "") << opt;  // alpha measured
      EXPECT_EQ(test::split_csv(rows[k])[3], "") << opt;  // r^2 not
    }
  }
  const auto r = test::run_biodem(video_cmd(dir / "frames", dir / "default"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_FALSE(contains(r.output, "r^2 needs 3")) << r.output;
}

// Defect 7: a file FFmpeg cannot open gives biodem's one line (with FFmpeg's reason, when it
// gives one), not FFmpeg's own lines before it.
TEST(VideoOutputs, UndecodableVideoIsOneLine) {
  test::TempDir dir("video_junk_file");
  for (const std::string name : {"junk.mp4", "junk.avi", "junk.mkv"}) {
    write_text(dir / name, "x\n");
    const auto r = test::run_biodem(video_cmd(dir / name, dir / "out"));
    expect_one_line_error(r, "cannot open video '" + (dir / name).string() + "'");
    EXPECT_FALSE(fs::exists(dir / "out" / "series.csv"));
  }
}

#endif  // BIODEM_HAVE_OPENCV
