// `biodem analyze DIR|SERIES.csv`: avalanche events and flowability descriptors from a
// centroid-angle series (SPEC 6, 11). Writes events.csv, descriptors.csv and plots (PNG + SVG)
// next to the series; prints a summary; warnings go to stderr prefixed "warning: ".
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>

#include "analysis/distributions.hpp"
#include "analysis/flowability.hpp"
#include "commands.hpp"
#include "core/error.hpp"
#include "output/analysis_files.hpp"
#include "output/output_dir.hpp"
#include "output/plot_writer.hpp"
#include "output/series_csv.hpp"

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
  double rebound_fraction = analysis::kDefaultReboundFraction;
  bool no_plots = false;
  bool sweep = false;
  CLI::Option* min_drop_opt = nullptr;
  CLI::Option* skip_s_opt = nullptr;
  CLI::Option* skip_rev_opt = nullptr;
  CLI::Option* rpm_opt = nullptr;
};

std::string fmt(double v, const char* f = "%.4g") {
  if (!std::isfinite(v)) return "-";
  char buf[48];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// Event markers stay readable up to about one marker per 12 px of plot width; beyond that (a
// 3-revolution biomass run has hundreds of events) the overview marks only the starts, small,
// and a second plot shows the first events in detail.
constexpr std::size_t kDetailedEvents = 60;
constexpr std::size_t kZoomEvents = 20;

output::Plot alpha_plot(const analysis::Series& s, const FlowabilityResult& r, std::size_t first_event,
                    std::size_t last_event, bool detailed) {
  output::Plot a;
  a.title = "Centroid angle";
  a.legend = output::LegendPlace::automatic;  // the corner with the fewest points: α rises to the top right
  a.x_label = "revolution (turns)";
  a.y_label = "alpha (deg)";
  a.note = std::to_string(r.detection.events.size()) + " events, threshold " +
           fmt(r.detection.threshold_deg, "%.3g") + " deg";
  output::PlotSeries line{"alpha", s.revolution, s.alpha_deg};
  line.line_width = 1.0;
  output::PlotSeries starts{"event start (UAS)", {}, {}, output::PlotStyle::markers,
                        output::Marker::triangle_down, 3};
  output::PlotSeries ends{"event end", {}, {}, output::PlotStyle::markers, output::Marker::triangle_up, 2};
  for (std::size_t k = first_event; k < last_event; ++k) {
    const auto& e = r.detection.events[k];
    starts.x.push_back(s.revolution[e.start_index]);
    starts.y.push_back(e.uas_deg);
    ends.x.push_back(s.revolution[e.end_index]);
    ends.y.push_back(s.alpha_deg[e.end_index]);
  }
  starts.marker_size = ends.marker_size = 3.5;
  if (detailed) {
    a.series = {line, starts, ends};
  } else {
    starts.marker_size = 2.0;
    starts.label = "event start";
    a.note += " (starts marked; alpha_vs_revolution_zoom shows the first " + std::to_string(kZoomEvents) + ")";
    a.series = {line, starts};
  }
  return a;
}

// Running median of v over a centred window of w samples, evaluated every `stride` samples.
void running_median(const std::vector<double>& x, const std::vector<double>& v, std::size_t w,
                    std::size_t stride, std::vector<double>& mx, std::vector<double>& mv) {
  std::vector<double> win;
  for (std::size_t i = 0; i < v.size(); i += stride) {
    const std::size_t lo = i >= w / 2 ? i - w / 2 : 0, hi = std::min(v.size(), i + w / 2 + 1);
    win.clear();
    for (std::size_t j = lo; j < hi; ++j)
      if (std::isfinite(v[j])) win.push_back(v[j]);
    if (win.empty()) continue;
    std::nth_element(win.begin(), win.begin() + static_cast<std::ptrdiff_t>(win.size() / 2), win.end());
    mx.push_back(x[i]);
    mv.push_back(win[win.size() / 2]);
  }
}

void write_plots(const fs::path& dir, const analysis::Series& s, const FlowabilityResult& r) {
  // alpha against revolution with the events marked.
  const std::size_t n_events = r.detection.events.size();
  const bool detailed = n_events <= kDetailedEvents;
  output::write_plot(alpha_plot(s, r, 0, n_events, detailed), dir / "alpha_vs_revolution");
  if (!detailed) {
    // The first kZoomEvents events with both markers, on their own range.
    output::Plot z = alpha_plot(s, r, 0, kZoomEvents, true);
    const auto& e0 = r.detection.events.front();
    const auto& e1 = r.detection.events[kZoomEvents - 1];
    const std::size_t i0 = e0.start_index > 20 ? e0.start_index - 20 : 0;
    const std::size_t i1 = std::min(s.size() - 1, e1.end_index + 20);
    double lo = s.alpha_deg[i0], hi = lo;
    for (std::size_t i = i0; i <= i1; ++i)
      if (std::isfinite(s.alpha_deg[i])) {
        lo = std::min(lo, s.alpha_deg[i]);
        hi = std::max(hi, s.alpha_deg[i]);
      }
    const double pad = 0.05 * std::max(hi - lo, 1e-3);
    z.x_min = s.revolution[i0];
    z.x_max = s.revolution[i1];
    z.y_min = lo - pad;
    z.y_max = hi + pad;
    z.title = "Centroid angle, first " + std::to_string(kZoomEvents) + " events";
    output::write_plot(z, dir / "alpha_vs_revolution_zoom");
  }

  // r^2 against time: every sample (grey) and, for long series, a running median over 1/300 of
  // the series (about 3 px of plot width) so that the trend reads through the sample-to-sample
  // scatter.
  bool has_r2 = false;
  for (double v : s.surface_r2) has_r2 = has_r2 || std::isfinite(v);
  if (has_r2) {
    output::Plot p;
    p.title = "Free-surface irregularity";
    p.x_label = "time (s)";
    p.y_label = "surface r^2";
    p.legend = output::LegendPlace::none;
    output::PlotSeries l{"r^2", s.time_s, s.surface_r2};
    l.line_width = 1.0;
    if (s.size() > 600) {
      const std::size_t w = std::max<std::size_t>(5, s.size() / 300);
      output::PlotSeries med{"running median", {}, {}};
      running_median(s.time_s, s.surface_r2, w, std::max<std::size_t>(1, w / 4), med.x, med.y);
      med.line_width = 2.0;
      med.color = 0;
      l.color = 7;  // grey
      l.label = "r^2 of each sample";
      p.legend = output::LegendPlace::bottom_right;
      p.note = "running median over " + std::to_string(w) + " samples";
      p.series = {l, med};
    } else {
      p.series = {l};
    }
    output::write_plot(p, dir / "r2_vs_time");
  }

  // Cumulative distributions.
  const auto table = analysis::descriptor_table();
  const char* stems[] = {"cdf_uas", "cdf_drop", "cdf_f", "cdf_r2"};
  for (std::size_t k = 0; k < table.size(); ++k) {
    if (r.values[k].empty()) continue;
    const auto cdf = analysis::empirical_cdf(r.values[k]);
    output::Plot p;
    p.title = std::string("Cumulative distribution: ") + table[k].label;
    p.x_label = table[k].label;
    p.y_label = "cumulative fraction";
    p.y_min = 0.0;
    p.y_max = 1.0;
    p.legend = output::LegendPlace::none;
    const auto& d = r.distributions[k];
    p.note = "n = " + std::to_string(d.count) + ", e10 = " + fmt(d.p10) + ", e50 = " +
             fmt(d.p50) + ", e90 = " + fmt(d.p90) + ", span = " + fmt(d.span, "%.3g");
    p.series = {output::PlotSeries{table[k].name, cdf.value, cdf.fraction, output::PlotStyle::step}};
    output::write_plot(p, dir / stems[k]);
  }
}

int run_analyze(const AnalyzeOptions& o) {
  const fs::path series_path = output::resolve_series_path(o.input);
  const output::SeriesFile file = output::read_series_csv(series_path);
  for (const auto& w : file.warnings) std::cerr << "warning: " << w << "\n";

  analysis::FlowabilityOptions fo;
  if (o.min_drop_opt->count()) fo.events.min_drop_deg = o.min_drop_deg;
  if (o.skip_s_opt->count()) fo.skip_s = o.skip_s;
  if (o.skip_rev_opt->count()) fo.skip_rev = o.skip_rev;
  if (o.rpm_opt->count()) fo.rpm = o.rpm;
  fo.events.rebound_fraction = o.rebound_fraction;
  const FlowabilityResult r = analysis::analyze_flowability(file.series, fo);
  for (const auto& w : r.warnings) std::cerr << "warning: " << w << "\n";

  const fs::path dir = series_path.parent_path().empty() ? fs::path(".") : series_path.parent_path();
  // The plots and sweep of an earlier analysis of this folder go first: this one may write fewer
  // (no zoom, no r^2, a distribution without values, --no-plots) and must not leave old ones
  // beside its tables.
  output::remove_analysis_plots(dir.string());
  if (std::error_code ec; !o.sweep) fs::remove(dir / "threshold_sweep.csv", ec);
  output::write_events_csv((dir / "events.csv").string(), r);
  output::write_descriptors_csv((dir / "descriptors.csv").string(), r);
  if (!o.no_plots) {
    // The plots draw alpha as the events were found on it: continuous across 270/-90 deg.
    analysis::Series drawn = file.series;
    drawn.alpha_deg = r.alpha_deg;
    write_plots(dir, drawn, r);
  }

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
  std::cout << ", rebound fraction " << fmt(r.detection.rebound_fraction, "%g");
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
  if (o.sweep) {
    const std::vector<double> hs(analysis::kSweepThresholdsDeg.begin(), analysis::kSweepThresholdsDeg.end());
    const auto rows = analysis::sweep_event_rule(s, fo, hs, analysis::sweep_rebound_fractions());
    output::write_sweep_csv(dir / "threshold_sweep.csv", "", rows, true);
    std::printf("event-rule sweep (threshold_sweep.csv):\n%5s %8s %7s %10s %10s %10s\n", "rho", "h_deg", "events",
                "uas_p50", "drop_p50", "f_p50");
    for (const auto& w : rows)
      std::printf("%5g %8g %7zu %10s %10s %10s\n", w.rebound_fraction, w.threshold_deg, w.events,
                  fmt(w.uas_p50).c_str(), fmt(w.drop_p50).c_str(), fmt(w.f_p50).c_str());
  }
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
  sub->add_option("--rebound-fraction", o->rebound_fraction,
                  "an avalanche ends only once alpha rose max(h, R x its drop so far) above its "
                  "minimum (default " + fmt(analysis::kDefaultReboundFraction, "%g") + "; 0: a rise of h)");
  sub->add_flag("--sweep", o->sweep,
                "also write threshold_sweep.csv: events and medians for thresholds 0.05 ... 2 deg "
                "and rebound fractions 0, 0.1, 0.15, 0.25, 0.5");
  sub->add_flag("--no-plots", o->no_plots, "write the CSV files only");
  return [o] {
    if (!output::plots_built()) o->no_plots = true;  // lean build without OpenCV: CSV files only
    return run_analyze(*o);
  };
}

}  // namespace biodem::cli
