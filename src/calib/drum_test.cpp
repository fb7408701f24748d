#include "calib/drum_test.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "analysis/distributions.hpp"
#include "analysis/flowability.hpp"
#include "core/error.hpp"
#include "output/analysis_files.hpp"
#include "output/output_dir.hpp"
#include "output/series_csv.hpp"

namespace biodem::calib {
namespace {

constexpr const char* kStatistics[] = {"mean", "p10", "p50", "p90", "span"};

double statistic(const analysis::Distribution& d, int k) {
  switch (k) {
    case 0: return d.mean;
    case 1: return d.p10;
    case 2: return d.p50;
    case 3: return d.p90;
    default: return d.span;
  }
}

std::string g17(double v) {
  if (std::isnan(v)) return "nan";
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

// An optional number of the job line: "-" when absent.
std::string opt(const std::optional<double>& v) { return v ? g17(*v) : "-"; }
std::optional<double> read_opt(const std::string& s) {
  if (s == "-") return std::nullopt;
  return std::stod(s);
}

}  // namespace

const std::vector<std::string>& drum_response_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const auto& d : analysis::descriptor_table())
      for (const char* s : kStatistics) n.push_back(std::string(d.name) + "_" + s);
    n.push_back("event_count");
    return n;
  }();
  return names;
}

std::string drum_response_unit(const std::string& response) {
  // span = (p90 - p10) / (p90 + p10) (SPEC 6) is a ratio, whatever the descriptor's unit.
  if (response.size() > 5 && response.compare(response.size() - 5, 5, "_span") == 0) return "-";
  if (response.rfind("uas_deg_", 0) == 0 || response.rfind("drop_deg_", 0) == 0) return "deg";
  if (response.rfind("f_percent_", 0) == 0) return "%";
  return "-";  // surface_r2_*, event_count
}

DrumMeasurement measure_drum(const std::string& out_dir, const DrumAnalysis& a) {
  DrumMeasurement m;
  analysis::FlowabilityResult r;
  try {
    const output::SeriesFile file = output::read_series_csv(out_dir + "/series.csv");
    for (const auto& w : file.warnings) m.warnings.push_back("WARNING: drum test: " + w);
    analysis::FlowabilityOptions fo;
    if (a.min_drop_deg) fo.events.min_drop_deg = *a.min_drop_deg;
    fo.skip_s = a.skip_s;
    fo.skip_rev = a.skip_rev;
    r = analysis::analyze_flowability(file.series, fo);
  } catch (const Error& e) {
    m.warnings.push_back(std::string("WARNING: drum test: the series cannot be analysed: ") + e.what());
    return m;
  }
  const auto table = analysis::descriptor_table();
  std::ostringstream csv;
  csv << "response,value,unit\n";
  std::string empty;  // descriptors without values
  for (std::size_t d = 0; d < table.size(); ++d) {
    if (r.distributions[d].count == 0) empty += std::string(empty.empty() ? "" : ", ") + table[d].name;
    for (int k = 0; k < 5; ++k) {
      const std::string name = std::string(table[d].name) + "_" + kStatistics[k];
      const double v = r.distributions[d].count ? statistic(r.distributions[d], k) : NAN;
      m.responses[name] = v;
      csv << name << ',' << (std::isfinite(v) ? output::csv_number(v, 12) : "") << ',' << drum_response_unit(name)
          << '\n';
    }
  }
  m.responses["event_count"] = static_cast<double>(r.detection.events.size());
  csv << "event_count," << r.detection.events.size() << ",-\n";
  if (!empty.empty())
    m.warnings.push_back("WARNING: drum test: no values of " + empty + " (" + std::to_string(r.detection.events.size()) +
                         " events): their responses are empty");
  for (const auto& w : r.warnings)  // (with empty responses only the bed carried over the top: the rest says why)
    if (empty.empty() || w.find("carried over the top") != std::string::npos)
      m.warnings.push_back("WARNING: drum test: " + w);
  // The files beside the series; a failed write is a warning (the responses are measured).
  try {
    output::write_events_csv(out_dir + "/events.csv", r);
    output::write_descriptors_csv(out_dir + "/descriptors.csv", r);
    output::write_file_atomic(out_dir + "/responses.csv", csv.str());
  } catch (const std::exception& e) {
    m.warnings.push_back(std::string("WARNING: drum test: the analysis files were not written: ") + e.what());
  }
  return m;
}

std::string encode_drum_line(const std::optional<DrumAnalysis>& a) {
  if (!a) return "-";
  return "drum " + opt(a->min_drop_deg) + " " + opt(a->skip_s) + " " + opt(a->skip_rev);
}

std::optional<DrumAnalysis> decode_drum_line(const std::string& line) {
  if (line == "-") return std::nullopt;
  std::istringstream in(line);
  std::string tag, x, y, z;
  in >> tag >> x >> y >> z;
  if (tag != "drum") throw Error("calibrate: bad job line \"" + line + "\"");
  return DrumAnalysis{read_opt(x), read_opt(y), read_opt(z)};
}

}  // namespace biodem::calib
