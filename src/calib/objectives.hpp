// The two objectives of a campaign (SPEC 7, docs/calibration.md): each is the weighted mean of the
// relative errors |response - target| / |target| of its responses. A missing response scores NaN
// (the campaign then scores the evaluation as failed).
#pragma once
#include <map>
#include <string>
#include <vector>

#include "calib/calib_file.hpp"

namespace biodem::calib {

/// All responses the objectives use, in a fixed order (o1's, then o2's new ones): the response
/// columns of evaluations.csv and pareto.csv.
std::vector<std::string> response_names(const CalibConfig& c);

/// Weighted mean relative error of `o`'s responses in `measured` against their targets.
double objective(const CalibConfig& c, const CalibObjective& o, const std::map<std::string, double>& measured);

}  // namespace biodem::calib
