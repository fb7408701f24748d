// A bulk-test calibration campaign (SPEC 7, 11; issue 9; docs/calibration.md): NSGA-II
// (calib/nsga2.hpp) over the parameters of a CALIB file; each evaluation runs the file's
// bulk-test cases with the parameters applied (calib/test_runs.hpp), on threads or MPI ranks
// (calib/scheduler.hpp), and scores the two objectives (calib/objectives.hpp).
//
// Files in the output folder: evaluations.csv (rows in (generation, index) order after each
// batch, so they do not depend on where the runs ran), cache.csv (every finished evaluation,
// appended at once: --resume re-uses it; a restarted campaign with the same seed asks for the
// same vectors in the same order), pareto.csv, plots and campaign.log.
#pragma once
#include <cstddef>
#include <string>

#include "calib/calib_file.hpp"
#include "calib/test_runs.hpp"
#include "core/error.hpp"

namespace biodem::calib {

class MpiJob;

struct CampaignOptions {
  std::string out_dir;
  int jobs = 1;         // test runs at once on this machine (child processes)
  bool resume = false;  // re-use out_dir/cache.csv of an interrupted campaign
  std::string evaluate_csv;
  /// `--evaluate FILE`: no search; evaluate the parameter vectors of FILE's rows (read_parameter_rows:
  /// a pareto.csv of a bulk-test campaign, to be narrowed by a drum test; SPEC 7) as one batch,
  /// generation 0, index = row, and write the same files (pareto.csv: the non-dominated rows).
  /// How a test runs; empty: `biodem run` as a child process of biodem_exe.
  TestRunner runner;
  /// The `biodem` that runs the tests; empty: this process's executable.
  std::string biodem_exe;
};

struct CampaignSummary {
  std::size_t evaluations = 0, pareto = 0;
  bool mpi_worker = false;  // an MPI rank > 0: it ran test cases for rank 0's campaign
};

/// Thrown when SIGINT or SIGTERM stopped the campaign (test_runs.hpp, CampaignSignals): the
/// batch in progress is not scored (its test runs wrote their checkpoints; none is taken for
/// failed), campaign.log says so, and `calibrate --resume` continues where it stopped, with the
/// result of an uninterrupted campaign. `biodem calibrate` prints what() and exits 128 + signal.
class CampaignStopped : public Error {
 public:
  CampaignStopped(int signal_number, const std::string& what) : Error(what), signal(signal_number) {}
  int signal;
};

/// Runs the campaign of `c` into options.out_dir. With `mpi` (rank 0 of an MPI job) the test runs
/// go to the other ranks. Throws biodem::Error on a folder that holds an earlier campaign (without
/// resume) or nothing to resume.
CampaignSummary run_campaign(const CalibConfig& c, const CampaignOptions& options, const MpiJob* mpi = nullptr);

/// `biodem calibrate CALIB --out DIR [--jobs N] [--resume]`: loads the file and runs its campaign.
/// Under mpirun (builds with MPI) rank 0 runs the campaign and the other ranks run test cases
/// (their summary says mpi_worker).
CampaignSummary calibrate(const std::string& calib_path, const CampaignOptions& options);

}  // namespace biodem::calib
