// `biodem compare DIR1 DIR2 ...`: the flowability descriptors of several samples side by side
// (SPEC 6, 11): per sample and descriptor the median, span and rank (I = worst flow ... N =
// best, ties share a rank), as compare.csv and a printed table, plus overlaid cumulative
// distributions (PNG + SVG). Each sample is analysed from its series.csv with the same options
// as `biodem analyze`.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "analysis/distributions.hpp"
#include "analysis/flowability.hpp"
#include "commands.hpp"
#include "core/error.hpp"
#include "io/plot_writer.hpp"
#include "io/series_csv.hpp"

namespace biodem::cli {

namespace {

namespace fs = std::filesystem;

struct CompareOptions {
  std::vector<std::string> inputs;
  std::vector<std::string> names;
  std::string out = ".";
  double min_drop_deg = 0.0, skip_s = 0.0, skip_rev = 0.0, rpm = 0.0;
  bool no_plots = false;
  CLI::Option* min_drop_opt = nullptr;
  CLI::Option* skip_s_opt = nullptr;
  CLI::Option* skip_rev_opt = nullptr;
  CLI::Option* rpm_opt = nullptr;
};

struct Sample {
  std::string name;
  fs::path series;
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

int run_compare(const CompareOptions& o) {
  if (o.inputs.empty()) throw Error("compare: give at least one sample folder or series file");
  if (!o.names.empty() && o.names.size() != o.inputs.size())
    throw Error("compare: --names has " + std::to_string(o.names.size()) + " names for " +
                std::to_string(o.inputs.size()) + " samples");

  analysis::FlowabilityOptions fo;
  if (o.min_drop_opt->count()) fo.events.min_drop_deg = o.min_drop_deg;
  if (o.skip_s_opt->count()) fo.skip_s = o.skip_s;
  if (o.skip_rev_opt->count()) fo.skip_rev = o.skip_rev;
  if (o.rpm_opt->count()) fo.rpm = o.rpm;

  std::vector<Sample> samples;
  std::set<std::string> used;
  for (std::size_t i = 0; i < o.inputs.size(); ++i) {
    Sample s;
    s.name = o.names.empty() ? default_name(o.inputs[i]) : o.names[i];
    if (s.name.empty()) s.name = "sample" + std::to_string(i + 1);
    for (int k = 2; used.count(s.name); ++k) s.name += "_" + std::to_string(k);
    used.insert(s.name);
    s.series = io::resolve_series_path(o.inputs[i]);
    const io::SeriesFile file = io::read_series_csv(s.series);
    for (const auto& w : file.warnings) std::cerr << "warning: " << s.name << ": " << w << "\n";
    try {
      s.result = analysis::analyze_flowability(file.series, fo);
    } catch (const Error& e) {
      throw Error(s.name + " (" + s.series.string() + "): " + e.what());
    }
    for (const auto& w : s.result.warnings) std::cerr << "warning: " << s.name << ": " << w << "\n";
    samples.push_back(std::move(s));
  }

  const fs::path out_dir = o.out;
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (!fs::is_directory(out_dir)) throw Error("cannot create output folder '" + o.out + "'");

  const auto table = analysis::descriptor_table();
  std::vector<std::vector<int>> ranks(table.size());
  for (std::size_t k = 0; k < table.size(); ++k) {
    std::vector<double> med;
    for (const auto& s : samples) med.push_back(s.result.distributions[k].p50);
    ranks[k] = analysis::rank_samples(med, table[k].worse);
  }

  const fs::path csv = out_dir / "compare.csv";
  {
    std::ofstream out(csv, std::ios::trunc);
    out << "sample,descriptor,count,mean,p10,median,p90,span,rank,rank_roman\n";
    for (std::size_t k = 0; k < table.size(); ++k)
      for (std::size_t i = 0; i < samples.size(); ++i) {
        const auto& d = samples[i].result.distributions[k];
        out << samples[i].name << ',' << table[k].name << ',' << d.count << ','
            << io::csv_number(d.mean) << ',' << io::csv_number(d.p10) << ','
            << io::csv_number(d.p50) << ',' << io::csv_number(d.p90) << ','
            << io::csv_number(d.span) << ',';
        if (ranks[k][i] > 0) out << ranks[k][i];
        out << ',' << (ranks[k][i] > 0 ? analysis::roman(ranks[k][i]) : "") << '\n';
      }
    if (!out) throw Error("cannot write '" + csv.string() + "'");
  }

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
      io::Plot p;
      p.title = std::string("Cumulative distributions: ") + table[k].label;
      p.x_label = table[k].label;
      p.y_label = "cumulative fraction";
      p.y_min = 0.0;
      p.y_max = 1.0;
      p.legend = io::LegendPlace::bottom_right;
      for (std::size_t i = 0; i < samples.size(); ++i) {
        const auto cdf = analysis::empirical_cdf(samples[i].result.values[k]);
        io::PlotSeries line{samples[i].name + " (" + analysis::roman(ranks[k][i]) + ")", cdf.value,
                            cdf.fraction, io::PlotStyle::step};
        line.color = static_cast<int>(i);
        p.series.push_back(std::move(line));
      }
      bool any = false;
      for (const auto& s : p.series) any = any || !s.x.empty();
      if (any) io::write_plot(p, out_dir / stems[k]);
    }
  }
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
                                    "event threshold for every sample, deg (default: per sample, "
                                    "max(8 x noise, 0.05 deg))");
  o->skip_s_opt = sub->add_option("--skip-s", o->skip_s, "skip the first T seconds of rotation");
  o->skip_rev_opt = sub->add_option("--skip-rev", o->skip_rev, "skip the first R revolutions");
  o->rpm_opt = sub->add_option("--rpm", o->rpm, "drum speed for every sample (default: from each series)");
  sub->add_flag("--no-plots", o->no_plots, "write compare.csv only");
  return [o] { return run_compare(*o); };
}

}  // namespace biodem::cli
