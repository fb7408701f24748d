// `biodem run`: insertion waves, phases (settle, rotate ...), sampling of the centroid-angle
// series, snapshots, trace, run.log, progress. SPEC 5 and 11.
#pragma once
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>

#include "case_file/case_parser.hpp"

namespace biodem::driver {

struct RunOptions {
  std::string out_dir;
  int threads = 0;      // 0: OpenMP default
  bool resume = false;
  bool progress_tty = false;
  bool profile = false;  // --profile: per-phase timers of the CPU step in run.log
  std::optional<config::Device> device;  // --device; absent: the case's [run] device (default cpu)
  /// Called once the checks have passed (case, device, output folder, the checkpoint file of a
  /// resume and its case), before the first computation: `biodem run` prints the case's warnings
  /// there, so that a run refused on bad input prints its one-line error alone. (One check comes
  /// later: a resumed insertion's state against the case, which only a damaged checkpoint of the
  /// same case can fail.)
  std::function<void()> on_start;
};

struct RunSummary {
  std::uint64_t steps = 0;
  double simulated_s = 0.0;
  double wall_s = 0.0;
  std::size_t bodies = 0, spheres = 0;
};

/// Thrown by run_case when SIGINT or SIGTERM stopped the run: the current step was finished and
/// a checkpoint written (also while particles are being inserted), so `--resume` continues bit
/// for bit. `biodem run` prints `what()` and exits with 128 + signal (130 SIGINT, 143 SIGTERM).
struct Interrupted : std::runtime_error {
  Interrupted(int signal_number, const std::string& what) : std::runtime_error(what), signal(signal_number) {}
  int signal;
};

RunSummary run_case(const case_file::LoadedCase& loaded, const RunOptions& options);

}  // namespace biodem::driver
