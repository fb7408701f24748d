// The files `biodem analyze` writes next to a series (docs/outputs.md): a fresh `biodem run`
// into the folder removes them, since they describe the series it replaces.
#pragma once

namespace biodem::output {

inline constexpr const char* kAnalysisTables[] = {"events.csv", "descriptors.csv", "threshold_sweep.csv"};
/// Plot stems; each is written as STEM.png and STEM.svg.
inline constexpr const char* kAnalysisPlots[] = {"alpha_vs_revolution", "alpha_vs_revolution_zoom", "r2_vs_time",
                                                 "cdf_uas", "cdf_drop", "cdf_f", "cdf_r2"};

}  // namespace biodem::output
