// The plots of a campaign (docs/outputs.md): the Pareto front (pareto.png/.svg) and each
// response against each parameter with its target (<response>_vs_<parameter>.png/.svg).
#pragma once
#include <string>

#include "calib/calib_file.hpp"
#include "calib/nsga2.hpp"

namespace biodem::calib {

void write_campaign_plots(const CalibConfig& c, const CampaignResult& r, const std::string& out_dir);

}  // namespace biodem::calib
