// `biodem analyze DIR|SERIES.csv`: avalanche events and flowability descriptors from a
// centroid-angle series (SPEC 6, 11). Writes events.csv, descriptors.csv and plots (PNG + SVG)
// next to the series; prints a summary; warnings go to stderr prefixed "warning: ".
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include "analysis/distributions.hpp"
#include "analysis/flowability.hpp"
#include "commands.hpp"
#include "core/error.hpp"
#include "io/plot_writer.hpp"
#include "io/series_csv.hpp"

namespace biodem::cli {

namespace {

namespace fs = std::filesystem;
using analysis::FlowabilityResult;

struct AnalyzeOptions {
  std::string input;
  double min_drop_deg = 0.0;
  double skip_s = 0.0;
  double skip_rev = 0.0;
  double rpm = 0.0;
  bool no_plots = false;
  CLI::Option* min_drop_opt = nullptr;
  CLI::Option* skip_s_opt = nullptr;
  CLI::Option* skip_rev_opt = nullptr;
  CLI::Option* rpm_opt = nullptr;
};

void write_events_csv(const fs::path& path, const FlowabilityResult& r) {
  std::ofstream out(path, std::ios::trunc);
  out << "start_time_s,start_revolution,uas_deg,end_time_s,drop_deg,interval_s,f_percent\n";
  for (const auto& e : r.detection.events) {
    out << io::csv_number(e.start_time_s, 12) << ',' << io::csv_number(e.start_revolution, 12)
        << ',' << io::csv_number(e.uas_deg) << ',' << io::csv_number(e.end_time_s, 12) << ','
        << io::csv_number(e.drop_deg) << ','
        << (e.interval_s ? io::csv_number(*e.interval_s, 12) : "") << ','
        << (e.f_percent ? io::csv_number(*e.f_percent) : "") << '\n';
  }
  if (!out) throw Error("cannot write '" + path.string() + "'");
}

void write_descriptors_csv(const fs::path& path, const FlowabilityResult& r) {
  std::ofstream out(path, std::ios::trunc);
  out << "descriptor,count,mean,p10,p50,p90,span\n";
  const auto table = analysis::descriptor_table();
  for (std::size_t k = 0; k < table.size(); ++k) {
    const auto& d = r.distributions[k];
    out << table[k].name << ',' << d.count << ',' << io::csv_number(d.mean) << ','
        << io::csv_number(d.p10) << ',' << io::csv_number(d.p50) << ','
        << io::csv_number(d.p90) << ',' << io::csv_number(d.span) << '\n';
  }
  if (!out) throw Error("cannot write '" + path.string() + "'");
}

std::string fmt(double v, const char* f = "%.4g") {
  if (!std::isfinite(v)) return "-";
  char buf[48];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

void write_plots(const fs::path& dir, const analysis::Series& s, const FlowabilityResult& r) {
  // alpha against revolution with the events marked.
  io::Plot a;
  a.title = "Centroid angle";
  a.x_label = "revolution (turns)";
  a.y_label = "alpha (deg)";
  a.note = std::to_string(r.detection.events.size()) + " events, threshold " +
           fmt(r.detection.threshold_deg, "%.3g") + " deg";
  io::PlotSeries line{"alpha", s.revolution, s.alpha_deg};
  line.line_width = 1.0;
  io::PlotSeries starts{"event start (UAS)", {}, {}, io::PlotStyle::markers,
                        io::Marker::triangle_down, 3};
  io::PlotSeries ends{"event end", {}, {}, io::PlotStyle::markers, io::Marker::triangle_up, 2};
  for (const auto& e : r.detection.events) {
    starts.x.push_back(s.revolution[e.start_index]);
    starts.y.push_back(e.uas_deg);
    ends.x.push_back(s.revolution[e.end_index]);
    ends.y.push_back(s.alpha_deg[e.end_index]);
  }
  starts.marker_size = ends.marker_size = 3.5;
  a.series = {line, starts, ends};
  io::write_plot(a, dir / "alpha_vs_revolution");

  // r^2 against time.
  bool has_r2 = false;
  for (double v : s.surface_r2) has_r2 = has_r2 || std::isfinite(v);
  if (has_r2) {
    io::Plot p;
    p.title = "Free-surface irregularity";
    p.x_label = "time (s)";
    p.y_label = "surface r^2";
    p.legend = io::LegendPlace::none;
    io::PlotSeries l{"r^2", s.time_s, s.surface_r2};
    l.line_width = 1.0;
    p.series = {l};
    io::write_plot(p, dir / "r2_vs_time");
  }

  // Cumulative distributions.
  const auto table = analysis::descriptor_table();
  const char* stems[] = {"cdf_uas", "cdf_drop", "cdf_f", "cdf_r2"};
  for (std::size_t k = 0; k < table.size(); ++k) {
    if (r.values[k].empty()) continue;
    const auto cdf = analysis::empirical_cdf(r.values[k]);
    io::Plot p;
    p.title = std::string("Cumulative distribution: ") + table[k].label;
    p.x_label = table[k].label;
    p.y_label = "cumulative fraction";
    p.y_min = 0.0;
    p.y_max = 1.0;
    p.legend = io::LegendPlace::none;
    const auto& d = r.distributions[k];
    p.note = "n = " + std::to_string(d.count) + ", e10 = " + fmt(d.p10) + ", e50 = " +
             fmt(d.p50) + ", e90 = " + fmt(d.p90) + ", span = " + fmt(d.span, "%.3g");
    p.series = {io::PlotSeries{table[k].name, cdf.value, cdf.fraction, io::PlotStyle::step}};
    io::write_plot(p, dir / stems[k]);
  }
}

int run_analyze(const AnalyzeOptions& o) {
  const fs::path series_path = io::resolve_series_path(o.input);
  const io::SeriesFile file = io::read_series_csv(series_path);
  for (const auto& w : file.warnings) std::cerr << "warning: " << w << "\n";

  analysis::FlowabilityOptions fo;
  if (o.min_drop_opt->count()) fo.events.min_drop_deg = o.min_drop_deg;
  if (o.skip_s_opt->count()) fo.skip_s = o.skip_s;
  if (o.skip_rev_opt->count()) fo.skip_rev = o.skip_rev;
  if (o.rpm_opt->count()) fo.rpm = o.rpm;
  const FlowabilityResult r = analysis::analyze_flowability(file.series, fo);
  for (const auto& w : r.warnings) std::cerr << "warning: " << w << "\n";

  const fs::path dir = series_path.parent_path().empty() ? fs::path(".") : series_path.parent_path();
  write_events_csv(dir / "events.csv", r);
  write_descriptors_csv(dir / "descriptors.csv", r);
  if (!o.no_plots) write_plots(dir, file.series, r);

  const auto& s = file.series;
  std::cout << "series: " << series_path.string() << " (" << s.size() << " samples; analysed "
            << r.samples_used << " from t = " << fmt(s.time_s[r.first_sample]) << " s)\n";
  std::cout << "drum speed: " << fmt(r.rpm) << " rpm"
            << (r.rpm_from_series ? " (from the revolution column)" : " (--rpm)") << "\n";
  std::cout << "event threshold: " << fmt(r.detection.threshold_deg, "%.3g") << " deg";
  if (r.detection.threshold_from_noise)
    std::cout << " (default: max(" << fmt(fo.events.noise_multiple, "%g") << " x noise "
              << fmt(r.detection.noise_sigma_deg, "%.3g") << " deg, " << fmt(fo.events.floor_deg, "%g")
              << " deg))";
  else
    std::cout << " (--min-drop-deg)";
  std::cout << "\nevents: " << r.detection.events.size() << "\n";
  std::printf("%-12s %7s %10s %10s %10s %10s %8s\n", "descriptor", "count", "mean", "p10", "p50",
              "p90", "span");
  const auto table = analysis::descriptor_table();
  for (std::size_t k = 0; k < table.size(); ++k) {
    const auto& d = r.distributions[k];
    std::printf("%-12s %7zu %10s %10s %10s %10s %8s\n", table[k].name, d.count,
                fmt(d.mean).c_str(), fmt(d.p10).c_str(), fmt(d.p50).c_str(), fmt(d.p90).c_str(),
                fmt(d.span, "%.3g").c_str());
  }
  std::fflush(stdout);
  std::cout << "wrote " << (dir / "events.csv").string() << ", descriptors.csv"
            << (o.no_plots ? "" : " and plots (PNG, SVG)") << "\n";
  return 0;
}

}  // namespace

Action register_analyze(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "analyze",
      "Avalanche events and flowability descriptors (UAS, avalanche size, f, surface r^2) from a "
      "centroid-angle series; writes events.csv, descriptors.csv and plots next to the series");
  auto o = std::make_shared<AnalyzeOptions>();
  sub->add_option("INPUT", o->input, "folder holding series.csv (from run or video), or a series CSV file")
      ->required();
  o->min_drop_opt = sub->add_option(
      "--min-drop-deg", o->min_drop_deg,
      "smallest drop of alpha that counts as an event, deg (default: max(8 x noise, 0.05 deg), "
      "noise estimated from the series)");
  o->skip_s_opt = sub->add_option("--skip-s", o->skip_s,
                                  "skip the first T seconds of the rotating part (initial transient)");
  o->skip_rev_opt = sub->add_option("--skip-rev", o->skip_rev,
                                    "skip the first R revolutions of the rotating part");
  o->rpm_opt = sub->add_option("--rpm", o->rpm,
                               "drum speed in rpm for f (default: slope of the revolution column)");
  sub->add_flag("--no-plots", o->no_plots, "write the CSV files only");
  return [o] { return run_analyze(*o); };
}

}  // namespace biodem::cli
