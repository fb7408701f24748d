// A persistent team of threads for the CPU step's parallel region (issue 11).
//
// Why not an OpenMP parallel region: on virtual machines a thread that waits for its partner by
// spinning on PAUSE (what libgomp does at barriers and between regions) or by sleeping lets the
// hypervisor take its core away, and the partner then waits for a host scheduler slice at the
// next barrier; the same 2-thread run took 385 or 900 us/step from one launch to the next
// (docs/performance.md). This team waits by reading an atomic in a plain loop, without PAUSE,
// so a waiting thread stays on its core like the busy thread it is. A thread that has waited
// for a while (200 us: far longer than a step's waits on a host that gives the team its cores)
// sleeps on the atomic (futex): workers with no job between steps, and threads at a barrier or
// waiting for the workers' end of a job on a host with fewer free cores than threads, where
// spinning would hold the core the awaited thread needs for a whole scheduler slice. A team
// larger than the CPUs the process may use (its affinity mask) spins 5 us only. The parallel loops around the step (list builds, wall candidates) run on the
// same team (for_each_index below), not on OpenMP threads that would share the cores with it.
//
// Use: team().run(n, job) runs job(me, n) on n threads (the caller is thread 0) and returns when
// all have finished; inside the job, barrier() waits until all n threads reached it (at once in
// a one-thread job). Jobs must not nest; jobs of several threads started from several threads
// run one after the other. The work each thread does is decided by `me` only, so results do not depend on
// which OS thread runs what.
#pragma once
#include <algorithm>
#include <atomic>
#include <cstddef>
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
  /// Whether the calling thread is running a job of the team (where run() must not be called).
  static bool in_job();
  /// How many waits at a barrier or for the end of a job went on asleep after their spin (a
  /// host with fewer free cores than threads, or a thread held up by its own work).
  std::uint64_t sleeps() const { return sleeps_.load(std::memory_order_relaxed); }
  /// How long the last job's threads spun before sleeping (microseconds): 200, or 5 where the
  /// team was larger than the CPUs the calling thread may run on.
  std::int64_t spin_us() const { return spin_us_.load(std::memory_order_relaxed); }

 private:
  void worker_loop(int me);
  std::vector<std::thread> workers_;                       // workers_[k] is me = k + 1
  std::atomic<std::uint64_t> generation_{0};               // bumped for each job
  alignas(64) std::atomic<int> finished_{0};               // workers done with the current job
  std::atomic<int> finish_sleepers_{0};                    // callers asleep on finished_
  alignas(64) std::atomic<int> arrived_{0};                // at the current barrier
  alignas(64) std::atomic<std::uint32_t> barrier_gen_{0};  // bumped when a barrier opens
  std::atomic<int> barrier_sleepers_{0};                   // threads asleep on barrier_gen_
  std::atomic<std::uint64_t> sleeps_{0};                   // see sleeps()
  // How long the current job's threads spin before they sleep (microseconds): set by each run()
  // from the team size against the CPUs the calling thread may use (one system call, well under
  // a microsecond against a step's hundred), read by the workers after the job's generation
  // (and by idle workers for their next wait).
  std::atomic<std::int64_t> spin_us_{200};
  const std::function<void(int, int)>* job_ = nullptr;
  int n_ = 1;
  std::mutex mutex_;
};

/// The process-wide team (created on first use, never destroyed: its threads are detached).
SpinTeam& team();

/// Runs f(k) for k = 0..count-1 on `threads` threads of the team, each taking the next k when it
/// is done with one (the caller is one of them; one thread: a plain loop). f must write disjoint
/// outputs, so that the result does not depend on which thread ran which k. Called inside a job
/// of the team, it runs the loop on the calling thread. Used for the
/// parallel loops around the step (list builds, wall candidates) instead of OpenMP: the team's
/// workers are spinning there anyway, while OpenMP's would have to be woken and would share the
/// cores with them.
template <class F>
void for_each_index(int threads, std::size_t count, F&& f) {
  if (threads <= 1 || count <= 1 || SpinTeam::in_job()) {  // (inside a job: jobs do not nest)
    for (std::size_t k = 0; k < count; ++k) f(k);
    return;
  }
  std::atomic<std::size_t> next{0};
  const int n = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(threads), count));
  team().run(n, [&](int, int) {
    for (std::size_t k = next.fetch_add(1, std::memory_order_relaxed); k < count;
         k = next.fetch_add(1, std::memory_order_relaxed))
      f(k);
  });
}

}  // namespace biodem
