// Where the test runs of a batch run: on N threads of this process (each starting a child
// process: `biodem calibrate --jobs N`), or on the ranks of an MPI job (`mpirun -np N biodem
// calibrate`: rank 0 runs NSGA-II and hands each job to the next free rank). Either way the
// results come back in job order, so the campaign's files do not depend on where a job ran.
#pragma once
#include <string>
#include <vector>

#include "calib/test_runs.hpp"

namespace biodem::calib {

/// Runs `jobs` on `threads` threads (at least one); results in job order.
std::vector<TestRun> run_on_threads(const std::vector<TestJob>& jobs, int threads, const TestRunner& run);

/// True in a build with MPI when this process was started by mpirun (OpenMPI sets
/// OMPI_COMM_WORLD_SIZE). Without it there is no MPI at all.
bool launched_by_mpirun();

/// An MPI job (only in builds with MPI): MPI_Init on construction, MPI_Finalize on destruction.
/// Rank 0 calls run() for each batch and stop_workers() at the end; the other ranks call serve().
class MpiJob {
 public:
  MpiJob();
  ~MpiJob();
  MpiJob(const MpiJob&) = delete;
  MpiJob& operator=(const MpiJob&) = delete;

  int rank() const { return rank_; }
  int size() const { return size_; }
  /// Rank 0: runs `jobs` on ranks 1 .. size-1; results in job order.
  std::vector<TestRun> run(const std::vector<TestJob>& jobs) const;
  /// Ranks > 0: run the jobs rank 0 sends (child processes of `biodem_exe`) until told to stop.
  void serve(const std::string& biodem_exe) const;
  /// Rank 0: tells the other ranks to return from serve().
  void stop_workers() const;

 private:
  int rank_ = 0, size_ = 1;
};

}  // namespace biodem::calib
