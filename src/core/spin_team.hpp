// A persistent team of threads for the CPU step's parallel region (issue 11).
//
// Why not an OpenMP parallel region: on virtual machines a thread that waits for its partner by
// spinning on PAUSE (what libgomp does at barriers and between regions) or by sleeping lets the
// hypervisor take its core away, and the partner then waits for a host scheduler slice at the
// next barrier; the same 2-thread run took 385 or 900 us/step from one launch to the next
// (docs/performance.md). This team waits by reading an atomic in a plain loop, without PAUSE,
// so a waiting thread stays on its core like the busy thread it is. Workers that find no work
// for a while (kIdleSpin) sleep on the atomic (futex), so they do not compete with OpenMP loops
// or other work between steps.
//
// Use: team().run(n, job) runs job(me, n) on n threads (the caller is thread 0) and returns when
// all have finished; inside the job, barrier() waits until all n threads reached it (at once in
// a one-thread job). Jobs must not nest; jobs of several threads started from several threads
// run one after the other. The work each thread does is decided by `me` only, so results do not depend on
// which OS thread runs what.
#pragma once
#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace biodem {

class SpinTeam {
 public:
  /// Runs job(me, n) for me = 0..n-1 on n threads; the calling thread is me = 0.
  void run(int n, const std::function<void(int, int)>& job);
  /// Called by all n threads of the current job: returns when all have called it.
  void barrier();

 private:
  void worker_loop(int me);
  std::vector<std::thread> workers_;                       // workers_[k] is me = k + 1
  std::atomic<std::uint64_t> generation_{0};               // bumped for each job
  alignas(64) std::atomic<int> finished_{0};               // workers done with the current job
  alignas(64) std::atomic<int> arrived_{0};                // at the current barrier
  alignas(64) std::atomic<std::uint64_t> barrier_gen_{0};  // bumped when a barrier opens
  const std::function<void(int, int)>* job_ = nullptr;
  int n_ = 1;
  std::mutex mutex_;
};

/// The process-wide team (created on first use, never destroyed: its threads are detached).
SpinTeam& team();

}  // namespace biodem
