#include "core/spin_team.hpp"

#include <chrono>

namespace biodem {
namespace {
// How long an idle worker keeps spinning before it sleeps: longer than the driver's work between
// two steps (a few microseconds) and the serial parts of a list build (below 100 us at 5k spheres).
constexpr std::chrono::microseconds kIdleSpin{200};
// Set while this thread runs a one-thread job: its barriers return at once.
thread_local bool tl_solo = false;
// Set while this thread runs any job of the team.
thread_local bool tl_in_job = false;
struct InJob {
  bool was = tl_in_job;
  InJob() { tl_in_job = true; }
  ~InJob() { tl_in_job = was; }
};
}  // namespace

bool SpinTeam::in_job() { return tl_in_job; }

void SpinTeam::run(int n, const std::function<void(int, int)>& job) {
  if (n > 255) n = 255;
  if (n <= 1) {
    tl_solo = true;
    {
      const InJob in;
      job(0, 1);
    }
    tl_solo = false;
    return;
  }
  const std::lock_guard<std::mutex> one_job_at_a_time(mutex_);  // callers on several threads queue
  while (static_cast<int>(workers_.size()) < n - 1) {
    const int me = static_cast<int>(workers_.size()) + 1;
    workers_.emplace_back([this, me] { worker_loop(me); });
    workers_.back().detach();
  }
  job_ = &job;
  n_ = n;
  finished_.store(0, std::memory_order_relaxed);
  arrived_.store(0, std::memory_order_relaxed);
  // The team size travels in the low byte of the generation word, so that a worker reads the
  // job number and whether it takes part in one atomic load.
  const std::uint64_t next = ((generation_.load(std::memory_order_relaxed) >> 8) + 1) << 8;
  generation_.store(next | static_cast<std::uint64_t>(n), std::memory_order_release);
  generation_.notify_all();
  auto wait_for_workers = [&] {
    while (finished_.load(std::memory_order_acquire) != n - 1) {
    }
    job_ = nullptr;
  };
  try {
    const InJob in;
    job(0, n);
  } catch (...) {
    // The workers still run the job (its data live in the caller's frame): let them finish
    // before the exception leaves. (A job that uses barrier() must not throw on one thread only.)
    wait_for_workers();
    throw;
  }
  wait_for_workers();
}

void SpinTeam::barrier() {
  if (tl_solo) return;
  const std::uint64_t g = barrier_gen_.load(std::memory_order_acquire);
  if (arrived_.fetch_add(1, std::memory_order_acq_rel) == n_ - 1) {
    arrived_.store(0, std::memory_order_relaxed);
    barrier_gen_.fetch_add(1, std::memory_order_release);
    return;
  }
  while (barrier_gen_.load(std::memory_order_acquire) == g) {
  }
}

void SpinTeam::worker_loop(int me) {
  std::uint64_t seen = 0;
  for (;;) {
    // Wait for the next job: spin (no PAUSE), then sleep on the generation counter.
    auto t0 = std::chrono::steady_clock::now();
    std::uint64_t g;
    for (std::uint32_t k = 1;; ++k) {
      g = generation_.load(std::memory_order_acquire);
      if (g != seen) break;
      if ((k & 1023u) == 0 && std::chrono::steady_clock::now() - t0 > kIdleSpin) {
        generation_.wait(seen, std::memory_order_acquire);
        t0 = std::chrono::steady_clock::now();
      }
    }
    seen = g;
    const int n = static_cast<int>(g & 0xffu);
    if (me < n) {
      {
        const InJob in;
        (*job_)(me, n);
      }
      finished_.fetch_add(1, std::memory_order_acq_rel);
    }
  }
}

SpinTeam& team() {
  static SpinTeam* t = new SpinTeam;  // never destroyed: detached workers may still read it at exit
  return *t;
}

}  // namespace biodem
