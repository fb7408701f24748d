#include "output/series_csv.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <string_view>

#include "core/error.hpp"

namespace biodem::output {

namespace fs = std::filesystem;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '"')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r' || s.back() == '"'))
    s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> cells;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    cells.push_back(trim(line.substr(start, comma == std::string_view::npos ? std::string_view::npos
                                                                            : comma - start)));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return cells;
}

// Parses a cell: empty or nan -> NaN; false if it is not a number.
bool parse_cell(std::string_view s, double& out) {
  if (s.empty()) {
    out = kNaN;
    return true;
  }
  if (s == "nan" || s == "NaN" || s == "NAN" || s == "-nan") {
    out = kNaN;
    return true;
  }
  if (s.front() == '+') s.remove_prefix(1);
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && ptr == s.data() + s.size();
}

std::string list_lines(const std::vector<std::size_t>& lines) {
  std::ostringstream o;
  const std::size_t shown = std::min<std::size_t>(lines.size(), 5);
  for (std::size_t i = 0; i < shown; ++i) o << (i ? ", " : "") << lines[i];
  if (lines.size() > shown) o << ", ... (" << lines.size() - shown << " more)";
  return o.str();
}

}  // namespace

fs::path resolve_series_path(const fs::path& p) {
  std::error_code ec;
  if (fs::is_directory(p, ec)) return p / "series.csv";
  return p;
}

SeriesFile read_series_csv(const fs::path& path) {
  const std::string name = path.string();
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error("series file '" + name + "' does not exist");
  if (fs::is_directory(path, ec)) throw Error("series file '" + name + "' is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open series file '" + name + "'");

  std::string line;
  std::size_t line_no = 0;
  std::vector<std::string> header;
  while (std::getline(in, line)) {
    ++line_no;
    std::string_view v = line;
    if (line_no == 1 && v.starts_with("\xEF\xBB\xBF")) v.remove_prefix(3);  // UTF-8 BOM
    if (trim(v).empty() || trim(v).front() == '#') continue;
    for (auto c : split(v)) header.emplace_back(c);
    break;
  }
  if (header.empty()) throw Error("series file '" + name + "' is empty");

  static constexpr std::array<const char*, 7> kColumns{
      "time_s", "revolution", "alpha_deg", "surface_r2", "surface_angle_deg", "kinetic_energy_j",
      "contacts"};
  std::array<int, 7> col{};
  for (std::size_t k = 0; k < kColumns.size(); ++k) {
    const auto it = std::find(header.begin(), header.end(), kColumns[k]);
    col[k] = it == header.end() ? -1 : static_cast<int>(it - header.begin());
    if (k < 3 && col[k] < 0) {
      std::string have;
      for (const auto& h : header) have += (have.empty() ? "" : ", ") + h;
      throw Error("series file '" + name + "' has no column '" + kColumns[k] +
                  "' (header: " + have + ")");
    }
  }

  SeriesFile out;
  auto& s = out.series;
  std::array<std::vector<double>*, 7> dest{&s.time_s,           &s.revolution,
                                           &s.alpha_deg,        &s.surface_r2,
                                           &s.surface_angle_deg, &s.kinetic_energy_j,
                                           &s.contacts};
  std::vector<std::size_t> skipped, rows_line;
  std::size_t superseded = 0;
  std::vector<std::size_t> restart_lines;
  std::array<double, 7> val{};
  while (std::getline(in, line)) {
    ++line_no;
    if (trim(line).empty() || trim(line).front() == '#') continue;
    const auto cells = split(line);
    if (cells.size() != header.size() && in.eof()) {
      // The last line, without its end of line, short of cells: a run killed while writing it.
      out.warnings.push_back("series file '" + name + "': the last line (" + std::to_string(line_no) + ") is cut short (" +
                             std::to_string(cells.size()) + " of " + std::to_string(header.size()) +
                             " cells, no end of line: a run killed while writing it?): skipped");
      break;
    }
    if (cells.size() != header.size()) {
      throw Error("series file '" + name + "' line " + std::to_string(line_no) + ": " +
                  std::to_string(cells.size()) + " cells, the header has " +
                  std::to_string(header.size()));
    }
    for (std::size_t k = 0; k < kColumns.size(); ++k) {
      val[k] = kNaN;
      if (col[k] < 0) continue;
      const auto cell = cells[static_cast<std::size_t>(col[k])];
      if (!parse_cell(cell, val[k]))
        throw Error("series file '" + name + "' line " + std::to_string(line_no) + ", column '" +
                    kColumns[k] + "': '" + std::string(cell) + "' is not a number");
    }
    if (!std::isfinite(val[0]) || !std::isfinite(val[1]) || !std::isfinite(val[2])) {
      skipped.push_back(line_no);
      continue;
    }
    if (!s.time_s.empty() && val[0] <= s.time_s.back()) {
      // A resumed run re-wrote samples: keep the newest rows from this time on. It writes again a
      // sample time it had written; a time that goes back to one no earlier row has is a file out
      // of time order, which would silently lose most of its rows here.
      const auto keep = static_cast<std::size_t>(
          std::lower_bound(s.time_s.begin(), s.time_s.end(), val[0]) - s.time_s.begin());
      const double tol = 1e-9 * std::max(1.0, std::abs(val[0]));
      const bool rewrite = (keep < s.time_s.size() && std::abs(s.time_s[keep] - val[0]) <= tol) ||
                           (keep > 0 && std::abs(s.time_s[keep - 1] - val[0]) <= tol);
      if (!rewrite)
        throw Error("series file '" + name + "' line " + std::to_string(line_no) + ": time_s " +
                    csv_number(val[0], 12) + " goes back from " + csv_number(s.time_s.back(), 12) +
                    " to a time no earlier row has: the rows are not in time order (sort them by time_s)");
      superseded += s.time_s.size() - keep;
      restart_lines.push_back(line_no);
      for (std::size_t k = 0; k < kColumns.size(); ++k)
        if (col[k] >= 0) dest[k]->resize(keep);
      rows_line.resize(keep);
    }
    for (std::size_t k = 0; k < kColumns.size(); ++k)
      if (col[k] >= 0) dest[k]->push_back(val[k]);
    rows_line.push_back(line_no);
  }
  out.skipped_rows = skipped.size();
  if (!skipped.empty())
    out.warnings.push_back("series file '" + name + "': skipped " +
                           std::to_string(skipped.size()) +
                           " row(s) with an empty or NaN time_s, revolution or alpha_deg (line " +
                           list_lines(skipped) + ")");
  if (superseded > 0)
    out.warnings.push_back("series file '" + name + "': time_s goes back at line " +
                           list_lines(restart_lines) + " (a resumed run?): " +
                           std::to_string(superseded) + " earlier row(s) replaced by later ones");
  if (s.time_s.empty()) {
    if (skipped.empty()) throw Error("series file '" + name + "' has no data rows");
    throw Error("series file '" + name + "' has no valid rows: every row lacks time_s, " +
                "revolution or alpha_deg");
  }
  return out;
}

std::string csv_number(double v, int digits) {
  if (!std::isfinite(v)) return "";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

SeriesWriter::SeriesWriter(const fs::path& path, bool append) {
  std::error_code ec;
  path_ = fs::is_directory(path, ec) ? path / "series.csv" : path;
  bool need_header = true;
  if (append && fs::exists(path_, ec) && fs::file_size(path_, ec) > 0) {
    std::ifstream in(path_);
    std::string first;
    std::getline(in, first);
    if (!first.empty() && first.back() == '\r') first.pop_back();
    if (first != kSeriesHeader)
      throw Error("cannot append to '" + path_.string() + "': its header is not a series.csv header");
    need_header = false;
  }
  out_.open(path_, append ? std::ios::app : std::ios::trunc);
  if (!out_) throw OutputError("cannot open '" + path_.string() + "' for writing");
  if (need_header) out_ << kSeriesHeader << '\n';
  out_.flush();
}

SeriesWriter::~SeriesWriter() {
  if (out_.is_open()) out_.flush();
}

void append_series_row(std::string& out, const SeriesRow& r) {
  auto opt = [](const std::optional<double>& v) { return v ? csv_number(*v) : std::string(); };
  ((((out += csv_number(r.time_s, 12)) += ',') += csv_number(r.revolution, 12)) += ',') += csv_number(r.alpha_deg);
  (((((out += ',') += opt(r.surface_r2)) += ',') += opt(r.surface_angle_deg)) += ',') += opt(r.kinetic_energy_j);
  out += ',';
  if (r.contacts) out += std::to_string(*r.contacts);
  out += ',';
  if (r.lost_bodies) out += std::to_string(*r.lost_bodies);
  out += '\n';
}

void SeriesWriter::write(const SeriesRow& r) {
  std::string row;
  append_series_row(row, r);
  out_ << row;
  if (++unflushed_ >= 50) flush();
}

void SeriesWriter::flush() {
  out_.flush();
  unflushed_ = 0;
  if (!out_) throw OutputError("writing '" + path_.string() + "' failed");
}

void write_sweep_csv(const std::filesystem::path& path, const std::string& sample,
                     const std::vector<analysis::SweepRow>& rows, bool header, bool with_sample) {
  std::ofstream out(path, header ? std::ios::trunc : std::ios::app);
  if (header)
    out << (with_sample ? "sample," : "") << "rebound_fraction,threshold_deg,events,uas_p50,drop_p50,f_p50\n";
  for (const auto& r : rows)
    out << (with_sample ? sample + "," : "") << csv_number(r.rebound_fraction) << ','
        << csv_number(r.threshold_deg) << ',' << r.events << ',' << csv_number(r.uas_p50) << ','
        << csv_number(r.drop_p50) << ',' << csv_number(r.f_p50) << '\n';
  if (!out) throw OutputError("cannot write '" + path.string() + "'");
}

}  // namespace biodem::output
