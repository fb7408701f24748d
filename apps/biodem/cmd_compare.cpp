// `biodem compare DIR1 DIR2 ...`: the flowability descriptors of several samples side by side
// (SPEC 6, 11): per sample and descriptor the median, span and rank (I = worst flow ... N =
// best, ties share a rank), as compare.csv and a printed table, plus overlaid cumulative
// distributions (PNG + SVG). Each sample is analysed from its series.csv with the same options
// as `biodem analyze`.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "analysis/distributions.hpp"
#include "analysis/flowability.hpp"
#include "commands.hpp"
#include "core/error.hpp"
#include "output/output_dir.hpp"
#include "output/plot_writer.hpp"
#include "output/series_csv.hpp"

namespace biodem::cli {

namespace {

namespace fs = std::filesystem;

struct CompareOptions {
  std::vector<std::string> inputs;
  std::vector<std::string> names;
  std::string out = ".";
  double min_drop_deg = 0.0, skip_s = 0.0, skip_rev = 0.0, rpm = 0.0;
  double rebound_fraction = analysis::kDefaultReboundFraction;
  bool no_plots = false;
  bool per_sample_threshold = false;
  bool sweep = false;
  CLI::Option* min_drop_opt = nullptr;
  CLI::Option* skip_s_opt = nullptr;
  CLI::Option* skip_rev_opt = nullptr;
  CLI::Option* rpm_opt = nullptr;
};

struct Sample {
  std::string name;
  fs::path series;
  analysis::Series data;
  analysis::FlowabilityResult result;
};

std::string default_name(const std::string& input) {
  fs::path p = fs::path(input).lexically_normal();
  if (p.has_filename() && p.filename() != "." && p.filename() != "..") {
    if (fs::is_directory(p)) return p.filename().string();
    // A series file: name it after its folder unless the file has its own name.
    if (p.stem() != "series" || !p.has_parent_path()) return p.stem().string();
    return p.parent_path().filename().string();
  }
  return fs::absolute(p).lexically_normal().parent_path().filename().string();
}

std::string fmt(double v, const char* f = "%.4g") {
  if (!std::isfinite(v)) return "-";
  char buf[48];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// The event-rule sweep of every sample: compare_sweep.csv and, unless --no-plots, the event count
// and the medians of UAS, drop and f against the threshold, one colour per sample, a line for the
// default rebound fraction and markers for none (rho = 0).
void write_sweep(const CompareOptions& o, const analysis::FlowabilityOptions& fo,
                 const std::vector<Sample>& samples, const fs::path& out_dir) {
  const std::vector<double> hs(analysis::kSweepThresholdsDeg.begin(), analysis::kSweepThresholdsDeg.end());
  auto rhos = analysis::sweep_rebound_fractions();
  if (std::find(rhos.begin(), rhos.end(), o.rebound_fraction) == rhos.end()) rhos.push_back(o.rebound_fraction);
  std::vector<std::vector<analysis::SweepRow>> all;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    all.push_back(analysis::sweep_event_rule(samples[i].data, fo, hs, rhos));
    output::write_sweep_csv(out_dir / "compare_sweep.csv", samples[i].name, all.back(), i == 0, true);
  }
  if (o.no_plots) return;
  struct Panel {
    const char* stem;
    const char* label;
    double analysis::SweepRow::*field;
  };
  const Panel panels[] = {{"compare_sweep_uas", "median UAS (deg)", &analysis::SweepRow::uas_p50},
                          {"compare_sweep_drop", "median avalanche size (deg)", &analysis::SweepRow::drop_p50},
                          {"compare_sweep_f", "median f (%)", &analysis::SweepRow::f_p50},
                          {"compare_sweep_events", "events", nullptr}};
  for (const auto& panel : panels) {
    output::Plot p;
    p.title = std::string("Event rule: ") + panel.label + " against the threshold";
    p.x_label = "threshold h (deg)";
    // From 0, and a little past the largest threshold: the markers at either end are drawn whole.
    p.x_min = 0.0;
    p.x_max = 1.04 * hs.back();
    p.y_label = panel.label;
    p.note = "line: rebound fraction " + fmt(o.rebound_fraction, "%g") + "; markers: rebound fraction 0";
    p.legend = output::LegendPlace::automatic;  // the corner with the fewest points
    if (!panel.field) p.y_min = 0.0;
    // The chosen rebound fraction as a line per sample; rho = 0 as markers of the same colour.
    std::vector<double> rhos{o.rebound_fraction};
    if (o.rebound_fraction != 0.0) rhos.push_back(0.0);
    for (std::size_t i = 0; i < samples.size(); ++i)
      for (double rho : rhos) {
        output::PlotSeries line;
        line.label = rho == o.rebound_fraction ? samples[i].name : "";
        line.color = static_cast<int>(i);
        line.style = rho == o.rebound_fraction ? output::PlotStyle::line : output::PlotStyle::markers;
        line.marker_size = 3.0;
        for (const auto& w : all[i])
          if (w.rebound_fraction == rho) {
            const double y = panel.field ? w.*panel.field : static_cast<double>(w.events);
            if (!std::isfinite(y)) continue;
            line.x.push_back(w.threshold_deg);
            line.y.push_back(y);
          }
        p.series.push_back(std::move(line));
      }
    output::write_plot(p, out_dir / panel.stem);
  }
}

int run_compare(const CompareOptions& o) {
  if (o.inputs.empty()) throw Error("compare: give at least one sample folder or series file");
  if (!o.names.empty() && o.names.size() != o.inputs.size())
    throw Error("compare: --names has " + std::to_string(o.names.size()) + " names for " +
                std::to_string(o.inputs.size()) + " samples");
  if (o.inputs.size() == 1)
    std::cerr << "warning: compare: one sample: its medians and spans are listed, and every rank is I (nothing to rank it "
                 "against)\n";

  analysis::FlowabilityOptions fo;
  if (o.min_drop_opt->count()) fo.events.min_drop_deg = o.min_drop_deg;
  if (o.skip_s_opt->count()) fo.skip_s = o.skip_s;
  if (o.skip_rev_opt->count()) fo.skip_rev = o.skip_rev;
  if (o.rpm_opt->count()) fo.rpm = o.rpm;
  fo.events.rebound_fraction = o.rebound_fraction;
  if (o.per_sample_threshold && o.min_drop_opt->count())
    throw Error("compare: give either --min-drop-deg or --per-sample-threshold");

  std::vector<Sample> samples;
  std::set<std::string> used;
  for (std::size_t i = 0; i < o.inputs.size(); ++i) {
    Sample s;
    s.name = o.names.empty() ? default_name(o.inputs[i]) : o.names[i];
    if (s.name.empty()) s.name = "sample" + std::to_string(i + 1);
    for (int k = 2; used.count(s.name); ++k) s.name += "_" + std::to_string(k);
    used.insert(s.name);
    s.series = output::resolve_series_path(o.inputs[i]);
    const output::SeriesFile file = output::read_series_csv(s.series);
    for (const auto& w : file.warnings) std::cerr << "warning: " << s.name << ": " << w << "\n";
    try {
      s.result = analysis::analyze_flowability(file.series, fo);
    } catch (const Error& e) {
      throw Error(s.name + " (" + s.series.string() + "): " + e.what());
    }
    s.data = file.series;
    samples.push_back(std::move(s));
  }

  // One event rule for every sample (issue 12): with a threshold chosen per sample from its own
  // noise, a noisier sample would lose its small events and the ranks would partly reflect the
  // noise. The common threshold is the largest of the samples' noise-based defaults (so it is
  // above every sample's noise); --per-sample-threshold restores one threshold per sample.
  std::string rule;
  if (o.min_drop_opt->count()) {
    rule = "--min-drop-deg " + fmt(o.min_drop_deg, "%.3g") + " deg for every sample";
  } else if (o.per_sample_threshold) {
    rule = "threshold per sample from its own noise (--per-sample-threshold)";
  } else {
    std::size_t noisiest = 0;
    for (std::size_t i = 1; i < samples.size(); ++i)
      if (samples[i].result.detection.threshold_deg > samples[noisiest].result.detection.threshold_deg) noisiest = i;
    fo.events.min_drop_deg = samples[noisiest].result.detection.threshold_deg;
    bool all_equal = true, all_floor = true;
    for (const auto& s : samples) {
      all_equal = all_equal && s.result.detection.threshold_deg == *fo.events.min_drop_deg;
      all_floor = all_floor && s.result.detection.threshold_deg == fo.events.floor_deg;
    }
    rule = fmt(*fo.events.min_drop_deg, "%.3g") + " deg for every sample (" +
           (samples.size() > 1 && all_equal
                ? std::string(all_floor ? "every sample's noise-based default is at the floor"
                                        : "every sample's noise-based default")
                : "the largest noise-based default: " + samples[noisiest].name) +
           ")";
    for (auto& s : samples) {
      const std::size_t own = s.result.values[0].size();
      const double own_h = s.result.detection.threshold_deg;
      s.result = analysis::analyze_flowability(s.data, fo);
      // A sample far less noisy than the noisiest (glass beads beside biomass, or a recording
      // sampled more finely) may lose most of its events to the common threshold: say so.
      const std::size_t kept = s.result.values[0].size();
      if (own >= 4 && 2 * kept <= own)  // (half its events or more lost)
        s.result.warnings.push_back("the common threshold " + fmt(*fo.events.min_drop_deg, "%.3g") + " deg keeps " +
                                    std::to_string(kept) + " of the " + std::to_string(own) +
                                    " events found at its own noise-based threshold " + fmt(own_h, "%.3g") +
                                    " deg: its small events are not counted (--per-sample-threshold keeps them; "
                                    "docs/analysis.md, section 3)");
    }
  }
  rule += ", rebound fraction " + fmt(o.rebound_fraction, "%g");
  for (const auto& s : samples)
    for (const auto& w : s.result.warnings) std::cerr << "warning: " << s.name << ": " << w << "\n";

  const fs::path out_dir = o.out;
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (!fs::is_directory(out_dir)) throw OutputError("cannot create output folder '" + o.out + "'");

  const auto table = analysis::descriptor_table();
  std::vector<std::vector<int>> ranks(table.size());
  for (std::size_t k = 0; k < table.size(); ++k) {
    std::vector<double> med;
    for (const auto& s : samples) med.push_back(s.result.distributions[k].p50);
    ranks[k] = analysis::rank_samples(med, table[k].worse);
  }

  const fs::path csv = out_dir / "compare.csv";
  {
    std::ostringstream out;
    out << "sample,descriptor,count,mean,p10,median,p90,span,rank,rank_roman\n";
    for (std::size_t k = 0; k < table.size(); ++k)
      for (std::size_t i = 0; i < samples.size(); ++i) {
        const auto& d = samples[i].result.distributions[k];
        out << samples[i].name << ',' << table[k].name << ',' << d.count << ','
            << output::csv_number(d.mean) << ',' << output::csv_number(d.p10) << ','
            << output::csv_number(d.p50) << ',' << output::csv_number(d.p90) << ','
            << output::csv_number(d.span) << ',';
        if (ranks[k][i] > 0) out << ranks[k][i];
        out << ',' << (ranks[k][i] > 0 ? analysis::roman(ranks[k][i]) : "") << '\n';
      }
    output::write_file_atomic(csv.string(), out.str());
  }

  std::cout << "event threshold: " << rule << "\n";
  std::size_t name_w = 6;
  for (const auto& s : samples) name_w = std::max(name_w, s.name.size());
  std::printf("%-12s %-*s %7s %10s %8s %5s\n", "descriptor", static_cast<int>(name_w), "sample",
              "count", "median", "span", "rank");
  for (std::size_t k = 0; k < table.size(); ++k)
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const auto& d = samples[i].result.distributions[k];
      std::printf("%-12s %-*s %7zu %10s %8s %5s\n", table[k].name, static_cast<int>(name_w),
                  samples[i].name.c_str(), d.count, fmt(d.p50).c_str(), fmt(d.span, "%.3g").c_str(),
                  analysis::roman(ranks[k][i]).c_str());
    }
  std::printf("ranks: I = worst flow ... %s = best (higher UAS, larger drop, larger f, lower r^2 "
              "are worse)\n",
              analysis::roman(static_cast<int>(samples.size())).c_str());
  std::fflush(stdout);

  if (!o.no_plots) {
    const char* stems[] = {"compare_cdf_uas", "compare_cdf_drop", "compare_cdf_f", "compare_cdf_r2"};
    for (std::size_t k = 0; k < table.size(); ++k) {
      output::Plot p;
      p.title = std::string("Cumulative distributions: ") + table[k].label;
      p.x_label = table[k].label;
      p.y_label = "cumulative fraction";
      p.y_min = 0.0;
      p.y_max = 1.0;
      p.legend = output::LegendPlace::bottom_right;
      for (std::size_t i = 0; i < samples.size(); ++i) {
        const auto cdf = analysis::empirical_cdf(samples[i].result.values[k]);
        output::PlotSeries line{samples[i].name + " (" + analysis::roman(ranks[k][i]) + ")", cdf.value,
                            cdf.fraction, output::PlotStyle::step};
        line.color = static_cast<int>(i);
        p.series.push_back(std::move(line));
      }
      bool any = false;
      for (const auto& s : p.series) any = any || !s.x.empty();
      if (any) output::write_plot(p, out_dir / stems[k]);
    }
  }
  if (o.sweep) write_sweep(o, fo, samples, out_dir);
  std::cout << "wrote " << csv.string() << (o.no_plots ? "" : " and plots (PNG, SVG)") << "\n";
  return 0;
}

}  // namespace

Action register_compare(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "compare",
      "Descriptor medians, spans and ranks (I = worst flow ... N = best) of several samples: "
      "compare.csv, a printed table and overlaid cumulative distributions");
  auto o = std::make_shared<CompareOptions>();
  sub->add_option("SAMPLES", o->inputs, "sample folders holding series.csv, or series CSV files")
      ->required();
  sub->add_option("--names", o->names, "one display name per sample (default: folder names)")
      ->expected(1, -1);
  sub->add_option("--out", o->out, "folder for compare.csv and the plots (default: .)");
  o->min_drop_opt = sub->add_option("--min-drop-deg", o->min_drop_deg,
                                    "event threshold for every sample, deg (default: the largest of "
                                    "the samples' max(8 x noise, 0.05 deg))");
  sub->add_flag("--per-sample-threshold", o->per_sample_threshold,
                "each sample's own noise-based threshold instead of one for all");
  sub->add_option("--rebound-fraction", o->rebound_fraction,
                  "an avalanche ends only once alpha rose max(h, R x its drop so far) above its "
                  "minimum (default " + fmt(analysis::kDefaultReboundFraction, "%g") + ")");
  sub->add_flag("--sweep", o->sweep,
                "also write compare_sweep.csv and compare_sweep_*.png: events and medians against "
                "the threshold (0.05 ... 2 deg) per sample");
  o->skip_s_opt = sub->add_option("--skip-s", o->skip_s, "skip the first T seconds of rotation");
  o->skip_rev_opt = sub->add_option("--skip-rev", o->skip_rev, "skip the first R revolutions");
  o->rpm_opt = sub->add_option("--rpm", o->rpm, "drum speed for every sample (default: from each series)");
  sub->add_flag("--no-plots", o->no_plots, "write compare.csv only");
  return [o] {
    if (!output::plots_built()) o->no_plots = true;  // lean build without OpenCV: CSV files only
    return run_compare(*o);
  };
}

}  // namespace biodem::cli
