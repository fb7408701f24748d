// `biodem run`: insertion waves, phases (settle, rotate ...), sampling of the centroid-angle
// series, snapshots, trace, run.log, progress. SPEC 5 and 11.
#pragma once
#include <optional>
#include <string>

#include "io/case_parser.hpp"

namespace biodem::driver {

struct RunOptions {
  std::string out_dir;
  int threads = 0;      // 0: OpenMP default
  bool resume = false;
  bool progress_tty = false;
  std::optional<config::Device> device;  // --device; absent: the case's [run] device (default cpu)
};

struct RunSummary {
  std::uint64_t steps = 0;
  double simulated_s = 0.0;
  double wall_s = 0.0;
  std::size_t bodies = 0, spheres = 0;
};

RunSummary run_case(const io::LoadedCase& loaded, const RunOptions& options);

}  // namespace biodem::driver
