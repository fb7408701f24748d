// The files `biodem analyze` writes next to a series (docs/outputs.md): a fresh `biodem run`
// into the folder removes them, since they describe the series it replaces.
#pragma once
#include <string>

#include "analysis/flowability.hpp"

namespace biodem::output {

inline constexpr const char* kAnalysisTables[] = {"events.csv", "descriptors.csv", "threshold_sweep.csv"};
/// Plot stems; each is written as STEM.png and STEM.svg.
inline constexpr const char* kAnalysisPlots[] = {"alpha_vs_revolution", "alpha_vs_revolution_zoom", "r2_vs_time",
                                                 "cdf_uas", "cdf_drop", "cdf_f", "cdf_r2"};

/// analyze's events.csv (one row per event) and descriptors.csv (one row per descriptor:
/// descriptor,count,mean,p10,p50,p90,span), each written whole through a temporary file and a
/// rename (write_file_atomic): a reader, or an analysis killed mid-write, sees the old file or the
/// complete new one. Shared by `biodem analyze` and the drum tests of `biodem calibrate`.
/// Removes an earlier analysis of the series in `dir`: the plots (remove_analysis_plots), or the
/// tables and the plots (remove_analysis_outputs). A run or `biodem video` that writes a new
/// series.csv removes both; `biodem analyze` removes the plots it will not write again.
void remove_analysis_plots(const std::string& dir);
void remove_analysis_outputs(const std::string& dir);

void write_events_csv(const std::string& path, const analysis::FlowabilityResult& r);
void write_descriptors_csv(const std::string& path, const analysis::FlowabilityResult& r);

}  // namespace biodem::output
