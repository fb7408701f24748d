// `biodem analyze` run again on a folder: the plots of the earlier analysis that this one does
// not write (a distribution without values, the zoom, r^2, or all of them with --no-plots) and an
// earlier --sweep table are removed, so that no plot is left describing another analysis.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "output/plot_writer.hpp"
#include "test_analysis_helpers.hpp"

using namespace biodem;
namespace fs = std::filesystem;

namespace {

// A sawtooth at 1 rpm, 10 Hz: alpha rises 8 deg over 4 s and falls back in 1 s, four times
// (events at 108 deg, drop 8 deg), or a constant alpha (no event); r^2 0.9 throughout.
void write_series(const fs::path& dir, bool events) {
  fs::create_directories(dir);
  std::ofstream out(dir / "series.csv", std::ios::trunc);
  out << "time_s,revolution,alpha_deg,surface_r2,kinetic_energy_j,contacts\n";
  for (int i = 0; i <= 200; ++i) {
    const double t = i / 10.0, ph = std::fmod(t, 5.0);
    const double a = !events ? 100.0 : ph <= 4.0 ? 100.0 + 2.0 * ph : 108.0 - 8.0 * (ph - 4.0);
    char row[128];
    std::snprintf(row, sizeof row, "%.12g,%.12g,%.10g,0.9,,\n", t, t / 60.0, a);
    out << row;
  }
}

}  // namespace

TEST(AnalysisCli, AnalyzingAgainRemovesThePlotsAndSweepOfTheEarlierAnalysis) {
  if (!biodem::output::plots_built()) GTEST_SKIP() << "lean build: no plots";
  test::TempDir dir("cli_reanalysis");
  write_series(dir / "s", true);
  auto r = test::run_biodem("analyze " + test::quote(dir / "s") + " --sweep");
  ASSERT_EQ(r.status, 0) << r.output;
  for (const char* f : {"cdf_uas.png", "cdf_drop.svg", "cdf_f.png", "cdf_r2.png", "threshold_sweep.csv"})
    ASSERT_TRUE(fs::exists(dir / "s" / f)) << f;
  // The same folder, now without events: no uas, drop or f distribution to plot.
  write_series(dir / "s", false);
  r = test::run_biodem("analyze " + test::quote(dir / "s"));
  ASSERT_EQ(r.status, 0) << r.output;
  for (const char* f : {"cdf_uas.png", "cdf_uas.svg", "cdf_drop.png", "cdf_f.svg", "threshold_sweep.csv"})
    EXPECT_FALSE(fs::exists(dir / "s" / f)) << f << " of the earlier analysis left behind";
  EXPECT_TRUE(fs::exists(dir / "s" / "cdf_r2.png"));
  EXPECT_TRUE(fs::exists(dir / "s" / "alpha_vs_revolution.svg"));
  // --no-plots: the tables only, no plot of before.
  r = test::run_biodem("analyze " + test::quote(dir / "s") + " --no-plots");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_FALSE(fs::exists(dir / "s" / "cdf_r2.png"));
  EXPECT_FALSE(fs::exists(dir / "s" / "alpha_vs_revolution.png"));
  EXPECT_TRUE(fs::exists(dir / "s" / "descriptors.csv"));
}
