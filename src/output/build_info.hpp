#pragma once
// Which build produced a result: run.log, campaign.log and `biodem --version` state it, since
// results are reproducible for a given build, device and thread count (README, determinism).
#include <string>

namespace biodem::output {

/// "biodem 0.1.0 (source <git commit>[-modified]; <compiler>, <build type>, …)": the source's
/// commit when the build ran (or "not a git checkout") and the settings that change results.
std::string build_description();

}  // namespace biodem::output
