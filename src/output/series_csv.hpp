// series.csv: the drum time series shared by `biodem run`, `biodem video` and `biodem analyze`
// (SPEC 11). Header row first, one row per sample, comma-separated, columns
//     time_s,revolution,alpha_deg,surface_r2,surface_angle_deg,kinetic_energy_j,contacts,lost_bodies
// time_s, revolution and alpha_deg are required; the others may be absent or have empty cells.
//
// Reading rules (docs/analysis.md):
//   * columns are found by name, in any order; unknown columns are ignored;
//   * blank lines and lines starting with '#' are skipped;
//   * a cell that is not a number (and not empty or "nan") is an error naming line and column;
//   * a row whose time_s, revolution or alpha_deg is empty or NaN is skipped (a video frame
//     without powder, a sample the engine could not measure) and reported in one warning;
//   * if time_s goes back (a run resumed from a checkpoint appended rows it had already
//     written), the later rows replace the earlier ones from that time on, with a warning.
#pragma once
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "analysis/flowability.hpp"
#include "analysis/series.hpp"

namespace biodem::output {

inline constexpr const char* kSeriesHeader =
    "time_s,revolution,alpha_deg,surface_r2,surface_angle_deg,kinetic_energy_j,contacts,lost_bodies";

struct SeriesFile {
  analysis::Series series;
  std::vector<std::string> warnings;
  std::size_t skipped_rows = 0;  // rows dropped for missing time, revolution or alpha
};

/// Reads a series.csv. Throws biodem::Error naming the file (and line/column) on a missing or
/// empty file, a missing required column, a non-numeric cell, a row with the wrong number of
/// cells, or no valid row at all.
SeriesFile read_series_csv(const std::filesystem::path& path);

/// A directory holding series.csv, or the CSV file itself.
std::filesystem::path resolve_series_path(const std::filesystem::path& dir_or_file);

struct SeriesRow {
  double time_s = 0.0;
  double revolution = 0.0;
  double alpha_deg = 0.0;  // NaN is written as an empty cell
  std::optional<double> surface_r2;
  std::optional<double> surface_angle_deg;
  std::optional<double> kinetic_energy_j;
  std::optional<std::int64_t> contacts;
  std::optional<std::int64_t> lost_bodies;  // bodies removed so far for leaving the drum (simulation)
};

/// Appends one row of series.csv to `out`: the cells and digits SeriesWriter writes (time and
/// revolution with 12 significant digits, the rest with 10, missing values empty), for a writer
/// that keeps the rows and writes the file whole (`biodem video`).
void append_series_row(std::string& out, const SeriesRow& r);

/// Appends rows to a series.csv. `path` is the file, or an existing directory in which
/// series.csv is opened. With append = false the file is replaced; with append = true rows are
/// added after the existing ones (the header is written only if the file is new or empty, and an
/// existing header must be the standard one). Missing values (nullopt or NaN) are empty cells.
/// Rows are flushed every 50 rows, on flush() and on destruction. Throws biodem::Error if the
/// file cannot be opened.
class SeriesWriter {
 public:
  SeriesWriter(const std::filesystem::path& path, bool append);
  ~SeriesWriter();
  SeriesWriter(const SeriesWriter&) = delete;
  SeriesWriter& operator=(const SeriesWriter&) = delete;

  void write(const SeriesRow& row);
  void flush();
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  std::ofstream out_;
  std::size_t unflushed_ = 0;
};

/// A number for a CSV cell: shortest form with `digits` significant digits; "" for NaN/inf.
std::string csv_number(double v, int digits = 10);

/// Writes an event-rule sweep (analysis::sweep_event_rule) as CSV: columns [sample,]
/// rebound_fraction, threshold_deg, events, uas_p50, drop_p50, f_p50. `sample` names the rows
/// (a first column when `with_sample`). Starts the file with a header row when `header`, else
/// appends. Throws biodem::Error when the file cannot be written.
void write_sweep_csv(const std::filesystem::path& path, const std::string& sample,
                     const std::vector<analysis::SweepRow>& rows, bool header, bool with_sample = false);

}  // namespace biodem::output
