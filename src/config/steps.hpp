// Steps for a length of simulated time: the one rounding rule of the run (phase lengths, output
// cadences, settle windows) and of `biodem check`'s report, so that the two say the same.
#pragma once
#include <cmath>
#include <cstdint>

namespace biodem::config {

/// round(seconds / dt) (SPEC 11; docs/case_file.md, [[phase]]).
inline std::uint64_t steps_for(double seconds, double dt) {
  return static_cast<std::uint64_t>(std::llround(seconds / dt));
}

}  // namespace biodem::config
