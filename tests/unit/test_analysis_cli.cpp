// The analysis commands driven through the built binary (SPEC 11): analyze, compare and video on
// synthetic data, and their messages on bad input (exit status 2, one line naming the problem).
#include <gtest/gtest.h>

#include <algorithm>

#include <cmath>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "output/series_csv.hpp"
#include "test_analysis_helpers.hpp"

using namespace biodem;
namespace fs = std::filesystem;

namespace {

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// A drum series at 0.5 rpm, 50 Hz: alpha rises 0.06 deg per sample and drops `drop` deg over
// two samples every `period` samples, starting at sample `first`; r^2 constant.
void write_series(const fs::path& dir, double drop, std::size_t period, double r2,
                  std::size_t n = 2000, std::size_t first = 100) {
  fs::create_directories(dir);
  output::SeriesWriter w(dir, false);
  double a = 40.0;
  for (std::size_t i = 0; i < n; ++i) {
    output::SeriesRow r;
    r.time_s = 0.02 * static_cast<double>(i);
    r.revolution = 0.5 * r.time_s / 60.0;
    const bool dropping = i > first && (i - first) % period > 0 && (i - first) % period <= 2;
    if (i > 0) a += dropping ? -drop / 2.0 : 0.06;
    r.alpha_deg = a;
    r.surface_r2 = r2;
    w.write(r);
  }
}

std::vector<std::vector<std::string>> read_csv(const fs::path& p) {
  std::vector<std::vector<std::string>> rows;
  for (const auto& l : test::read_lines(p)) rows.push_back(test::split_csv(l));
  return rows;
}

}  // namespace

TEST(AnalysisCli, AnalyzeWritesEventsDescriptorsAndPlots) {
  test::TempDir dir("cli_analyze");
  write_series(dir / "run", 3.0, 100, 0.95);  // events at 100, 200, ... 1900: 19 events
  const auto r = test::run_biodem("analyze " + test::quote(dir / "run"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "events: 19")) << r.output;
  EXPECT_TRUE(contains(r.output, "0.5 rpm")) << r.output;

  const auto ev = read_csv(dir / "run" / "events.csv");
  ASSERT_EQ(ev.size(), 20u);
  EXPECT_EQ(ev[0], (std::vector<std::string>{"start_time_s", "start_revolution", "uas_deg", "end_time_s",
                                              "drop_deg", "interval_s", "f_percent"}));
  EXPECT_NEAR(std::stod(ev[1][0]), 2.0, 1e-9);
  EXPECT_NEAR(std::stod(ev[1][4]), 3.0, 1e-6);
  EXPECT_NEAR(std::stod(ev[1][5]), 2.0, 1e-9);
  EXPECT_NEAR(std::stod(ev[1][6]), 0.5 * 2.0 / 60.0 * 100.0, 1e-6);  // f = rpm T / 60 * 100 %
  EXPECT_EQ(ev.back()[5], "");  // no interval after the last event
  EXPECT_EQ(ev.back()[6], "");

  const auto de = read_csv(dir / "run" / "descriptors.csv");
  ASSERT_EQ(de.size(), 5u);
  EXPECT_EQ(de[0], (std::vector<std::string>{"descriptor", "count", "mean", "p10", "p50", "p90", "span"}));
  EXPECT_EQ(de[1][0], "uas_deg");
  EXPECT_EQ(de[2][0], "drop_deg");
  EXPECT_EQ(de[3][0], "f_percent");
  EXPECT_EQ(de[4][0], "surface_r2");
  EXPECT_EQ(de[1][1], "19");
  EXPECT_EQ(de[3][1], "18");
  EXPECT_NEAR(std::stod(de[2][4]), 3.0, 1e-6);
  EXPECT_NEAR(std::stod(de[4][4]), 0.95, 1e-9);
  EXPECT_NEAR(std::stod(de[4][6]), 0.0, 1e-12);
  for (const char* stem : {"alpha_vs_revolution", "r2_vs_time", "cdf_uas", "cdf_drop", "cdf_f"}) {
    EXPECT_TRUE(fs::file_size(dir / "run" / (std::string(stem) + ".svg")) > 1000) << stem;
    EXPECT_FALSE(cv::imread((dir / "run" / (std::string(stem) + ".png")).string()).empty()) << stem;
  }
  const std::string svg = test::read_text(dir / "run" / "alpha_vs_revolution.svg");
  EXPECT_TRUE(contains(svg, "revolution (turns)"));
  EXPECT_TRUE(contains(svg, "alpha (deg)"));

  // Options: a threshold above the drops finds nothing; --skip-s drops the early events.
  const auto big = test::run_biodem("analyze " + test::quote(dir / "run" / "series.csv") +
                                    " --min-drop-deg 5 --no-plots");
  ASSERT_EQ(big.status, 0) << big.output;
  EXPECT_TRUE(contains(big.output, "events: 0")) << big.output;
  EXPECT_TRUE(contains(big.output, "warning: no events found")) << big.output;
  const auto skip = test::run_biodem("analyze " + test::quote(dir / "run") + " --skip-s 10 --no-plots");
  ASSERT_EQ(skip.status, 0) << skip.output;
  EXPECT_TRUE(contains(skip.output, "events: 14")) << skip.output;  // starts at t >= 10 s
}

TEST(AnalysisCli, AnalyzeBadInputs) {
  test::TempDir dir("cli_analyze_bad");
  auto r = test::run_biodem("analyze " + test::quote(dir / "missing"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_TRUE(contains(r.output, "biodem: error: series file")) << r.output;
  EXPECT_TRUE(contains(r.output, "does not exist")) << r.output;

  { std::ofstream(dir / "empty.csv"); }
  r = test::run_biodem("analyze " + test::quote(dir / "empty.csv"));
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, "is empty")) << r.output;

  { std::ofstream(dir / "two.csv") << "time_s,revolution,alpha_deg\n0,0,40\n0.02,0.0001,40.1\n"; }
  r = test::run_biodem("analyze " + test::quote(dir / "two.csv"));
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, "too few samples")) << r.output;

  { std::ofstream(dir / "nan.csv") << "time_s,revolution,alpha_deg\n0,0,nan\n0.02,0.0001,nan\n"; }
  r = test::run_biodem("analyze " + test::quote(dir / "nan.csv"));
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, "no valid rows")) << r.output;

  { std::ofstream(dir / "still.csv") << "time_s,revolution,alpha_deg\n0,0,40\n0.02,0,40.1\n0.04,0,40.2\n"; }
  r = test::run_biodem("analyze " + test::quote(dir / "still.csv"));
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, "give --rpm")) << r.output;
  r = test::run_biodem("analyze " + test::quote(dir / "still.csv") + " --rpm 0.5 --no-plots");
  EXPECT_EQ(r.status, 0) << r.output;

  { std::ofstream(dir / "word.csv") << "time_s,revolution,alpha_deg\n0,0,40\n0.02,0.0001,abc\n"; }
  r = test::run_biodem("analyze " + test::quote(dir / "word.csv"));
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(contains(r.output, "line 3, column 'alpha_deg': 'abc' is not a number")) << r.output;
}

// Command-line errors (SPEC 11): one line naming the option, status 2, before anything runs;
// --help and --version status 0. (CLI11 alone printed two lines with statuses 104-109, and for
// --threads -1 a range up to 1.8e308.)
TEST(AnalysisCli, CommandLineErrorsAreOneLineNamingTheOption) {
  struct Case {
    std::string args, names;
  };
  const std::vector<Case> cases = {
      {"run case.toml --out o --threads -1", "--threads: must be at least 0, got -1"},
      {"run case.toml --out o --threads abc", "--threads: must be a whole number, got 'abc'"},
      {"run case.toml --out o --threads 1.5", "--threads: must be a whole number"},
      {"calibrate c.toml --out d --jobs 0", "--jobs: must be at least 1, got 0"},
      {"run case.toml", "--out is required"},
      {"run case.toml --out o --device tpu", "--device"},
      {"run case.toml --out o --bogus", "--bogus"},
      {"analyze x.csv --min-drop-deg abc", "--min-drop-deg"},
      {"", "subcommand is required"},
      {"bogus case.toml", "unknown command 'bogus' (expected one of run, check, analyze, compare, video, calibrate"},
  };
  for (const auto& c : cases) {
    const auto r = test::run_biodem(c.args);
    EXPECT_EQ(r.status, 2) << c.args << ": " << r.output;
    EXPECT_TRUE(contains(r.output, "biodem: error: ")) << c.args << ": " << r.output;
    EXPECT_TRUE(contains(r.output, c.names)) << c.args << ": " << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << c.args << ": " << r.output;
  }
  EXPECT_EQ(test::run_biodem("--help").status, 0);
  EXPECT_EQ(test::run_biodem("run --help").status, 0);
  // --version names the build: the source's commit (or that it was no git checkout) and the
  // settings that change results, as run.log and campaign.log do.
  const auto v = test::run_biodem("--version");
  EXPECT_EQ(v.status, 0);
  EXPECT_TRUE(std::regex_match(v.output, std::regex("biodem [0-9]+\\.[0-9]+\\.[0-9]+ \\(source ([0-9a-f]{12}(-modified|-unknown-state)?|not "
                                                    "a git checkout); (GNU|Clang)[^\n]*, (Release|Debug|RelWithDebInfo|MinSizeRel)[^\n]*\\)\n")))
      << v.output;
}

// Four samples: glass-like (small frequent drops), two biomass-like with equal drops (a tie),
// and one in between. Ranks I (worst) ... IV (best) per descriptor, ties share a rank.
TEST(AnalysisCli, CompareRanksSamples) {
  test::TempDir dir("cli_compare");
  write_series(dir / "glass", 0.4, 20, 0.99);
  write_series(dir / "raw", 8.0, 200, 0.80);
  write_series(dir / "mild", 8.0, 150, 0.90);
  write_series(dir / "torrefied", 2.0, 50, 0.95);
  const auto r = test::run_biodem("compare " + test::quote(dir / "raw") + " " + test::quote(dir / "mild") +
                                  " " + test::quote(dir / "torrefied") + " " + test::quote(dir / "glass") +
                                  " --out " + test::quote(dir / "cmp"));
  ASSERT_EQ(r.status, 0) << r.output;
  const auto rows = read_csv(dir / "cmp" / "compare.csv");
  ASSERT_EQ(rows.size(), 1u + 4 * 4);
  EXPECT_EQ(rows[0][0], "sample");
  auto rank = [&](const std::string& sample, const std::string& desc) {
    for (const auto& row : rows)
      if (row[0] == sample && row[1] == desc) return row[8];
    return std::string("?");
  };
  EXPECT_EQ(rank("raw", "drop_deg"), "1");
  EXPECT_EQ(rank("mild", "drop_deg"), "1");  // tie
  EXPECT_EQ(rank("torrefied", "drop_deg"), "3");
  EXPECT_EQ(rank("glass", "drop_deg"), "4");
  EXPECT_EQ(rank("raw", "f_percent"), "1");
  EXPECT_EQ(rank("mild", "f_percent"), "2");
  EXPECT_EQ(rank("glass", "f_percent"), "4");
  EXPECT_EQ(rank("raw", "surface_r2"), "1");
  EXPECT_EQ(rank("glass", "surface_r2"), "4");
  EXPECT_TRUE(contains(r.output, "rank")) << r.output;
  EXPECT_TRUE(fs::exists(dir / "cmp" / "compare_cdf_drop.png"));
  EXPECT_TRUE(fs::exists(dir / "cmp" / "compare_cdf_uas.svg"));

  const auto bad = test::run_biodem("compare " + test::quote(dir / "raw") + " --names a b");
  EXPECT_EQ(bad.status, 2);
  EXPECT_TRUE(contains(bad.output, "--names")) << bad.output;

  // One sample: listed, ranked I, and said to have nothing to rank against.
  const auto one = test::run_biodem("compare " + test::quote(dir / "raw") + " --no-plots --out " + test::quote(dir / "one"));
  EXPECT_EQ(one.status, 0) << one.output;
  EXPECT_TRUE(contains(one.output, "warning: compare: one sample")) << one.output;
  EXPECT_FALSE(contains(r.output, "warning: compare: one sample")) << r.output;
}

// A folder of frames: flat beds at known tilts (alpha = 90 deg + tilt within 0.5 deg), one
// corrupt file (warned about and skipped), a non-image file (ignored). Then --rotation cw on the
// mirrored frames, and the errors for an empty or missing folder and a frame without a disc.
TEST(AnalysisCli, VideoWritesSeriesAndSkipsCorruptFrames) {
  test::TempDir dir("cli_video");
  const fs::path frames = dir / "frames", mirrored = dir / "mirrored";
  fs::create_directories(frames);
  fs::create_directories(mirrored);
  test::DrumImage d;
  const std::vector<double> tilt{20.0, 24.0, 28.0, 0.0, 32.0, 22.0};
  for (std::size_t k = 0; k < tilt.size(); ++k) {
    const cv::Mat img = test::backlit_image(d, test::drawn_bed(d, test::flat_surface(tilt[k], -50.0)));
    cv::Mat flipped;
    cv::flip(img, flipped, 1);
    char name[32];
    std::snprintf(name, sizeof name, "img_%zu.png", k * 2 + (k == 5 ? 10 : 0));  // img_20 sorts last
    ASSERT_TRUE(cv::imwrite((frames / name).string(), img));
    ASSERT_TRUE(cv::imwrite((mirrored / name).string(), flipped));
  }
  { std::ofstream(frames / "img_3.png") << "this is not a png"; }
  { std::ofstream(frames / "notes.txt") << "camera settings"; }
  // A real PNG cut short (a copy interrupted), sorted last: skipped with the same one line, and
  // without libpng's own "libpng error: Read Error" line before it.
  fs::copy_file(frames / "img_0.png", frames / "img_21.png");
  fs::resize_file(frames / "img_21.png", fs::file_size(frames / "img_21.png") / 2);

  const auto r = test::run_biodem("video " + test::quote(frames) + " --fps 50 --rpm 0.5 --out " +
                                  test::quote(dir / "out") + " --quiet");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "warning: skipped 2 unreadable frame(s): img_3.png")) << r.output;
  EXPECT_TRUE(contains(r.output, "img_21.png")) << r.output;
  EXPECT_FALSE(contains(r.output, "libpng")) << r.output;
  const auto rows = read_csv(dir / "out" / "series.csv");
  ASSERT_EQ(rows.size(), 1u + tilt.size());
  EXPECT_EQ(rows[0][0], "time_s");
  // Sorted by name in natural order: img_0 img_2 img_3 (bad) img_4 img_6 img_8 img_20.
  const std::vector<double> expected_time{0.0, 0.02, 0.06, 0.08, 0.10, 0.12};
  for (std::size_t k = 0; k < tilt.size(); ++k) {
    const auto& row = rows[k + 1];
    ASSERT_EQ(row.size(), 8u);  // ... contacts, lost_bodies (empty for a video)
    EXPECT_NEAR(std::stod(row[0]), expected_time[k], 1e-12);
    EXPECT_NEAR(std::stod(row[1]), 0.5 * expected_time[k] / 60.0, 1e-12);
    EXPECT_NEAR(std::stod(row[2]), 90.0 + tilt[k], 0.5) << "frame " << k;
    EXPECT_NEAR(std::stod(row[4]), tilt[k], 0.5) << "frame " << k;
    EXPECT_EQ(row[5], "");  // kinetic energy and contacts left empty
    EXPECT_EQ(row[6], "");
  }
  EXPECT_TRUE(fs::exists(dir / "out" / "video_check.png"));

  const auto cw = test::run_biodem("video " + test::quote(mirrored) + " --fps 50 --rpm 0.5 --out " +
                                   test::quote(dir / "out_cw") + " --rotation cw --quiet");
  ASSERT_EQ(cw.status, 0) << cw.output;
  const auto cw_rows = read_csv(dir / "out_cw" / "series.csv");
  ASSERT_EQ(cw_rows.size(), 1u + tilt.size());
  for (std::size_t k = 0; k < tilt.size(); ++k)
    EXPECT_NEAR(std::stod(cw_rows[k + 1][2]), 90.0 + tilt[k], 0.5) << "frame " << k;

  // Given centre and radius, and a fixed threshold, give the same result.
  const auto given = test::run_biodem("video " + test::quote(frames) +
                                      " --fps 50 --rpm 0.5 --center-px 300 300 --radius-px 250 --threshold 120"
                                      " --quiet --out " + test::quote(dir / "out_given"));
  ASSERT_EQ(given.status, 0) << given.output;
  EXPECT_NEAR(std::stod(read_csv(dir / "out_given" / "series.csv")[1][2]), 90.0 + tilt[0], 0.5);

  fs::create_directories(dir / "none");
  { std::ofstream(dir / "none" / "readme.txt") << "x"; }
  auto e = test::run_biodem("video " + test::quote(dir / "none") + " --fps 50 --rpm 0.5 --out " +
                            test::quote(dir / "o2"));
  EXPECT_EQ(e.status, 2);
  EXPECT_TRUE(contains(e.output, "biodem: error: no frames")) << e.output;
  e = test::run_biodem("video " + test::quote(dir / "absent") + " --fps 50 --rpm 0.5 --out " +
                       test::quote(dir / "o3"));
  EXPECT_EQ(e.status, 2);
  EXPECT_TRUE(contains(e.output, "does not exist")) << e.output;

  fs::create_directories(dir / "grey");
  cv::imwrite((dir / "grey" / "f0.png").string(), cv::Mat(200, 200, CV_8UC1, cv::Scalar(128)));
  e = test::run_biodem("video " + test::quote(dir / "grey") + " --fps 50 --rpm 0.5 --out " +
                       test::quote(dir / "o4"));
  EXPECT_EQ(e.status, 2);
  EXPECT_TRUE(contains(e.output, "could not find the drum disc")) << e.output;

  e = test::run_biodem("video " + test::quote(frames) + " --fps 0 --rpm 0.5 --out " + test::quote(dir / "o5"));
  EXPECT_EQ(e.status, 2);
  EXPECT_TRUE(contains(e.output, "--fps must be > 0")) << e.output;
}

// The video path end to end: the series from frames goes through analyze.
TEST(AnalysisCli, VideoSeriesIsReadyForAnalyze) {
  test::TempDir dir("cli_video_analyze");
  const fs::path frames = dir / "frames";
  fs::create_directories(frames);
  test::DrumImage d;
  d.size = 240;
  d.cx = d.cy = 120.0;
  d.radius = 110.0;
  // Tilt rises 0.5 deg per frame and drops 4 deg every 20 frames.
  double tilt = 20.0;
  for (int k = 0; k < 80; ++k) {
    if (k > 0) tilt += (k % 20 == 0) ? -4.0 : 0.5;
    char name[32];
    std::snprintf(name, sizeof name, "f%03d.png", k);
    cv::imwrite((frames / name).string(), test::backlit_image(d, test::drawn_bed(d, test::flat_surface(tilt, -25.0))));
  }
  auto r = test::run_biodem("video " + test::quote(frames) + " --fps 10 --rpm 1 --quiet --out " + test::quote(dir / "out"));
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_biodem("analyze " + test::quote(dir / "out") + " --no-plots");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "events: 3")) << r.output;
  EXPECT_TRUE(contains(r.output, "1 rpm")) << r.output;
}

namespace {
std::size_t count_of(const std::string& s, const std::string& part) {
  std::size_t n = 0;
  for (auto at = s.find(part); at != std::string::npos; at = s.find(part, at + 1)) ++n;
  return n;
}
}  // namespace

// Issue 12, item 4: a 3-revolution series (18,000 samples at 50 Hz, 0.5 rpm) with 450 events.
// The overview marks only the event starts (one small marker per event, no end markers: 450 + 1
// in the legend), a zoom plot shows the first 20 events with starts and ends (40 + 2), and the r^2
// plot adds a running median. With 19 events the overview keeps both markers (38 + 2).
TEST(AnalysisCli, PlotsOfLongSeriesWithHundredsOfEvents) {
  test::TempDir dir("cli_long_plots");
  write_series(dir / "long", 3.0, 40, 0.9, 18000, 20);
  const auto r = test::run_biodem("analyze " + test::quote(dir / "long"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "events: 450")) << r.output;
  const std::string svg = test::read_text(dir / "long" / "alpha_vs_revolution.svg");
  EXPECT_EQ(count_of(svg, "<polygon"), 450u + 1u);
  EXPECT_TRUE(contains(svg, "alpha_vs_revolution_zoom shows the first 20"));
  const std::string zoom = test::read_text(dir / "long" / "alpha_vs_revolution_zoom.svg");
  EXPECT_EQ(count_of(zoom, "<polygon"), 40u + 2u);
  EXPECT_FALSE(cv::imread((dir / "long" / "alpha_vs_revolution_zoom.png").string()).empty());
  EXPECT_TRUE(contains(test::read_text(dir / "long" / "r2_vs_time.svg"), "running median"));

  write_series(dir / "short", 3.0, 100, 0.95);
  ASSERT_EQ(test::run_biodem("analyze " + test::quote(dir / "short")).status, 0);
  EXPECT_EQ(count_of(test::read_text(dir / "short" / "alpha_vs_revolution.svg"), "<polygon"), 38u + 2u);
  EXPECT_FALSE(fs::exists(dir / "short" / "alpha_vs_revolution_zoom.svg"));
}

// Issue 12: compare applies one event rule to every sample. Sample "noisy" has 0.05 deg Gaussian
// noise (default threshold 8 sigma ~ 0.4 deg) and "clean" none (threshold 0.05 deg); both have
// 3 deg avalanches every 100 samples and 0.15 deg small drops in between. With one rule (the
// default: the larger threshold for both) neither counts the small drops: 19 events each; with
// --per-sample-threshold the clean sample also counts its 19 small drops (38).
TEST(AnalysisCli, CompareUsesOneThresholdForAllSamples) {
  test::TempDir dir("cli_compare_rule");
  for (const char* name : {"clean", "noisy"}) {
    fs::create_directories(dir / name);
    output::SeriesWriter w(dir / name, false);
    test::Noise rng(3);
    double a = 40.0;
    for (std::size_t i = 0; i < 2000; ++i) {
      output::SeriesRow r;
      r.time_s = 0.02 * static_cast<double>(i);
      r.revolution = 0.5 * r.time_s / 60.0;
      const std::size_t k = i % 100;
      if (i > 100 && (k == 1 || k == 2)) a -= 1.5;                   // 3 deg avalanche at 100, 200, ...
      else if (i > 100 && k == 51) a -= 0.15 + 0.06;                 // 0.15 deg drop at 150, 250, ...
      else if (i > 0) a += 0.06;
      r.alpha_deg = a + (std::string(name) == "noisy" ? rng.gaussian(0.05) : 0.0);
      w.write(r);
    }
  }
  auto count = [&](const fs::path& csv, const std::string& sample) {
    for (const auto& row : read_csv(csv))
      if (row[0] == sample && row[1] == "uas_deg") return row[2];
    return std::string("?");
  };
  const auto r = test::run_biodem("compare " + test::quote(dir / "clean") + " " + test::quote(dir / "noisy") +
                                  " --no-plots --out " + test::quote(dir / "one"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "for every sample (the largest noise-based default: noisy)")) << r.output;
  EXPECT_EQ(count(dir / "one" / "compare.csv", "clean"), "19");
  EXPECT_EQ(count(dir / "one" / "compare.csv", "noisy"), "19");
  // The clean sample loses half its events to the common threshold: compare warns, naming it.
  EXPECT_TRUE(contains(r.output, "warning: clean: the common threshold")) << r.output;
  EXPECT_TRUE(contains(r.output, "keeps 19 of the 38 events")) << r.output;
  EXPECT_FALSE(contains(r.output, "warning: noisy: the common threshold")) << r.output;
  const auto p = test::run_biodem("compare " + test::quote(dir / "clean") + " " + test::quote(dir / "noisy") +
                                  " --no-plots --per-sample-threshold --out " + test::quote(dir / "per"));
  ASSERT_EQ(p.status, 0) << p.output;
  EXPECT_EQ(count(dir / "per" / "compare.csv", "clean"), "38");
  EXPECT_EQ(count(dir / "per" / "compare.csv", "noisy"), "19");
  // Two noise-free samples tie at the 0.05 deg floor: the line says so instead of naming the
  // first sample as the noisiest.
  const auto tie = test::run_biodem("compare " + test::quote(dir / "clean") + " " + test::quote(dir / "clean") +
                                    " --names a b --no-plots --out " + test::quote(dir / "tie"));
  ASSERT_EQ(tie.status, 0) << tie.output;
  EXPECT_TRUE(contains(tie.output, "0.05 deg for every sample (every sample's noise-based default is at the floor)"))
      << tie.output;

  // --sweep: events against the threshold; the clean sample's 0.15 deg drops count below 0.15 deg
  // only; 7 thresholds x 5 rebound fractions per sample; plots written.
  const auto w = test::run_biodem("compare " + test::quote(dir / "clean") + " " + test::quote(dir / "noisy") +
                                  " --sweep --out " + test::quote(dir / "sweep"));
  ASSERT_EQ(w.status, 0) << w.output;
  const auto rows = read_csv(dir / "sweep" / "compare_sweep.csv");
  ASSERT_EQ(rows.size(), 1u + 2u * 7u * 5u);
  EXPECT_EQ(rows[0], (std::vector<std::string>{"sample", "rebound_fraction", "threshold_deg", "events", "uas_p50",
                                                "drop_p50", "f_p50"}));
  auto events_at = [&](const std::string& sample, const std::string& rho, const std::string& h) {
    for (const auto& row : rows)
      if (row[0] == sample && row[1] == rho && row[2] == h) return row[3];
    return std::string("?");
  };
  EXPECT_EQ(events_at("clean", "0.15", "0.1"), "38");
  EXPECT_EQ(events_at("clean", "0.15", "0.25"), "19");
  EXPECT_EQ(events_at("clean", "0", "2"), "19");
  for (const char* stem : {"compare_sweep_events", "compare_sweep_uas", "compare_sweep_drop", "compare_sweep_f"})
    EXPECT_FALSE(cv::imread((dir / "sweep" / (std::string(stem) + ".png")).string()).empty()) << stem;
}
