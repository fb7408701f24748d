// series.csv reading and writing (SPEC 11): round trip, optional columns, and clear errors on bad
// files (missing, empty, missing column, non-numeric cell, NaN rows, restarts).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <string>

#include "core/error.hpp"
#include "output/series_csv.hpp"
#include "test_analysis_helpers.hpp"

using namespace biodem;

namespace {

void write_file(const std::filesystem::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::trunc | std::ios::binary);
  out << text;
}

// The message of the biodem::Error thrown by reading `p` ("" if none).
std::string read_error(const std::filesystem::path& p) {
  try {
    output::read_series_csv(p);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

TEST(AnalysisSeriesCsv, WriterAndReaderRoundTrip) {
  test::TempDir dir("series_roundtrip");
  {
    output::SeriesWriter w(dir.path(), false);  // a folder: opens series.csv in it
    for (int i = 0; i < 120; ++i) {
      output::SeriesRow r;
      r.time_s = 0.02 * i;
      r.revolution = 0.5 * r.time_s / 60.0;
      r.alpha_deg = 40.0 + 0.01 * i;
      if (i % 2 == 0) r.surface_r2 = 0.9 + 1e-4 * i;
      if (i % 3 == 0) r.surface_angle_deg = std::numeric_limits<double>::quiet_NaN();
      r.kinetic_energy_j = 1.25e-7 * i;
      r.contacts = 1000 + i;
      w.write(r);
    }
  }
  const auto lines = test::read_lines(dir / "series.csv");
  ASSERT_EQ(lines.size(), 121u);
  EXPECT_EQ(lines[0], output::kSeriesHeader);
  EXPECT_EQ(test::split_csv(lines[2]).size(), 8u);
  EXPECT_EQ(test::split_csv(lines[2])[3], "");  // missing r^2 is an empty cell

  const auto f = output::read_series_csv(dir / "series.csv");
  EXPECT_TRUE(f.warnings.empty());
  const auto& s = f.series;
  ASSERT_EQ(s.size(), 120u);
  EXPECT_NEAR(s.time_s[77], 0.02 * 77, 1e-12);
  EXPECT_NEAR(s.revolution[77], 0.5 * 0.02 * 77 / 60.0, 1e-13);  // 12 significant digits
  EXPECT_NEAR(s.alpha_deg[77], 40.77, 1e-9);
  EXPECT_NEAR(s.surface_r2[76], 0.9076, 1e-9);
  EXPECT_TRUE(std::isnan(s.surface_r2[77]));
  EXPECT_TRUE(std::isnan(s.surface_angle_deg[3]));
  EXPECT_NEAR(s.kinetic_energy_j[77], 1.25e-7 * 77, 1e-18);
  EXPECT_DOUBLE_EQ(s.contacts[77], 1077.0);

  // Appending keeps one header.
  {
    output::SeriesWriter w(dir / "series.csv", true);
    w.write(output::SeriesRow{2.4, 0.02, 41.0, {}, {}, {}, {}, {}});
  }
  EXPECT_EQ(test::read_lines(dir / "series.csv").size(), 122u);
  EXPECT_EQ(output::read_series_csv(dir / "series.csv").series.size(), 121u);
}

// Only the three required columns, in another order, with CRLF line ends and blank lines.
TEST(AnalysisSeriesCsv, MinimalColumnsInAnyOrder) {
  test::TempDir dir("series_minimal");
  write_file(dir / "s.csv", "alpha_deg,time_s,revolution,extra\r\n40,0,0,x\r\n\r\n40.1,0.02,0.0001,y\r\n40.2,0.04,0.0002,\r\n");
  const auto f = output::read_series_csv(dir / "s.csv");
  ASSERT_EQ(f.series.size(), 3u);
  EXPECT_DOUBLE_EQ(f.series.alpha_deg[2], 40.2);
  EXPECT_DOUBLE_EQ(f.series.time_s[1], 0.02);
  EXPECT_TRUE(f.series.surface_r2.empty());
}

TEST(AnalysisSeriesCsv, BadFilesGiveClearMessages) {
  test::TempDir dir("series_bad");
  EXPECT_TRUE(contains(read_error(dir / "nope.csv"), "does not exist"));
  write_file(dir / "empty.csv", "");
  EXPECT_TRUE(contains(read_error(dir / "empty.csv"), "is empty"));
  write_file(dir / "header.csv", "time_s,revolution,alpha_deg\n");
  EXPECT_TRUE(contains(read_error(dir / "header.csv"), "no data rows"));
  write_file(dir / "nocol.csv", "time_s,revolution,angle\n0,0,40\n");
  const std::string nocol = read_error(dir / "nocol.csv");
  EXPECT_TRUE(contains(nocol, "no column 'alpha_deg'")) << nocol;
  write_file(dir / "text.csv", "time_s,revolution,alpha_deg\n0,0,40\n0.02,0.0001,forty\n");
  const std::string text = read_error(dir / "text.csv");
  EXPECT_TRUE(contains(text, "line 3")) << text;
  EXPECT_TRUE(contains(text, "'forty' is not a number")) << text;
  write_file(dir / "short.csv", "time_s,revolution,alpha_deg\n0,0\n");
  EXPECT_TRUE(contains(read_error(dir / "short.csv"), "line 2: 2 cells"));
  write_file(dir / "allnan.csv", "time_s,revolution,alpha_deg\n0,0,nan\n0.02,0.0001,\n");
  EXPECT_TRUE(contains(read_error(dir / "allnan.csv"), "no valid rows"));
}

// NaN/empty alpha (a frame without powder) is skipped with one warning naming the lines; a time
// that goes back (a resumed run) replaces the earlier rows.
TEST(AnalysisSeriesCsv, NaNRowsAreSkippedAndRestartsReplaceRows) {
  test::TempDir dir("series_nan");
  write_file(dir / "s.csv",
             "time_s,revolution,alpha_deg,surface_r2\n"
             "0,0,40,0.9\n0.02,0.0001,nan,0.9\n0.04,0.0002,,\n0.06,0.0003,40.3,\n"
             "0.08,0.0004,40.4,0.95\n0.06,0.0003,41.3,0.97\n0.08,0.0004,41.4,0.98\n0.1,0.0005,41.5,0.99\n");
  const auto f = output::read_series_csv(dir / "s.csv");
  EXPECT_EQ(f.skipped_rows, 2u);
  ASSERT_EQ(f.warnings.size(), 2u);
  EXPECT_TRUE(contains(f.warnings[0], "skipped 2 row(s)")) << f.warnings[0];
  EXPECT_TRUE(contains(f.warnings[0], "line 3, 4")) << f.warnings[0];
  EXPECT_TRUE(contains(f.warnings[1], "goes back")) << f.warnings[1];
  ASSERT_EQ(f.series.size(), 4u);
  EXPECT_EQ(f.series.time_s, (std::vector<double>{0.0, 0.06, 0.08, 0.1}));
  EXPECT_DOUBLE_EQ(f.series.alpha_deg[1], 41.3);
  EXPECT_DOUBLE_EQ(f.series.surface_r2[3], 0.99);
}

// Rows out of time order are an error naming the line (before, each step back was taken for a
// resumed run and the shuffled file below kept 2 of its 6 rows, with only a warning); a step back
// to a time an earlier row has stays a resumed run's re-written samples.
TEST(AnalysisSeriesCsv, RowsOutOfTimeOrderAreAnError) {
  test::TempDir dir("series_order");
  write_file(dir / "shuffled.csv",
             "time_s,revolution,alpha_deg\n0.04,0.0002,40.2\n0.1,0.0005,40.5\n0.02,0.0001,40.1\n"
             "0.08,0.0004,40.4\n0,0,40\n0.06,0.0003,40.3\n");
  const std::string e = read_error(dir / "shuffled.csv");
  EXPECT_TRUE(contains(e, "line 4: time_s 0.02 goes back from 0.1 to a time no earlier row has")) << e;
  write_file(dir / "reversed.csv", "time_s,revolution,alpha_deg\n0.1,0.0005,40.5\n0.08,0.0004,40.4\n0.06,0.0003,40.3\n");
  EXPECT_TRUE(contains(read_error(dir / "reversed.csv"), "line 3: time_s 0.08 goes back"));
  write_file(dir / "resumed.csv",
             "time_s,revolution,alpha_deg\n0,0,40\n0.02,0.0001,40.1\n0.04,0.0002,40.2\n0.02,0.0001,41.1\n"
             "0.04,0.0002,41.2\n0.06,0.0003,41.3\n");
  const auto f = output::read_series_csv(dir / "resumed.csv");
  EXPECT_EQ(f.series.time_s, (std::vector<double>{0.0, 0.02, 0.04, 0.06}));
  EXPECT_DOUBLE_EQ(f.series.alpha_deg[1], 41.1);
}

// A last line cut short without its end of line (a run killed with SIGKILL while the writer
// flushed) is skipped with a warning; a short line that ends its line, or one in the middle,
// stays an error (before, the cut last line made the whole series unreadable).
TEST(AnalysisSeriesCsv, LastLineCutShortIsSkippedWithAWarning) {
  test::TempDir dir("series_cut");
  write_file(dir / "cut.csv", "time_s,revolution,alpha_deg,contacts\n0,0,40,5\n0.02,0.0001,40.1,5\n0.04,0.0002,40.2,5\n0.06,0.00");
  const auto f = output::read_series_csv(dir / "cut.csv");
  EXPECT_EQ(f.series.size(), 3u);
  ASSERT_EQ(f.warnings.size(), 1u);
  EXPECT_TRUE(contains(f.warnings[0], "the last line (5) is cut short (2 of 4 cells")) << f.warnings[0];
  write_file(dir / "ended.csv", "time_s,revolution,alpha_deg,contacts\n0,0,40,5\n0.02,0.0001\n");
  EXPECT_TRUE(contains(read_error(dir / "ended.csv"), "line 3: 2 cells"));
  write_file(dir / "middle.csv", "time_s,revolution,alpha_deg,contacts\n0,0\n0.02,0.0001,40.1,5");
  EXPECT_TRUE(contains(read_error(dir / "middle.csv"), "line 2: 2 cells"));
}

TEST(AnalysisSeriesCsv, WriterRefusesAForeignFileAndUnwritablePath) {
  test::TempDir dir("series_writer_bad");
  write_file(dir / "other.csv", "a,b\n1,2\n");
  EXPECT_THROW(output::SeriesWriter(dir / "other.csv", true), Error);
  EXPECT_THROW(output::SeriesWriter(dir / "missing_folder" / "series.csv", false), Error);
}
