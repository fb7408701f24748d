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

/// A time that is a whole number of steps, given as that number times dt: the engines' clocks
/// are sums of dt added one step at a time, whose rounding shows in the 12 digits of series.csv
/// (3.48000000001 for 3.48); the outputs write this instead.
inline double whole_steps_time(double t, double dt) { return static_cast<double>(std::llround(t / dt)) * dt; }

}  // namespace biodem::config
