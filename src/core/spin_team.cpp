#include "core/spin_team.hpp"

#include <sched.h>

#include <chrono>

namespace biodem {
namespace {
// How long a waiting thread keeps spinning before it sleeps: longer than the driver's work
// between two steps (a few microseconds), the serial parts of a list build (below 100 us at 5k
// spheres) and the threads' imbalance at a barrier of a step on cores of their own (tens of us).
// Only a thread whose partner has no core (a host running more threads than it has cores) waits
// longer; it then sleeps instead of holding the core for the rest of its scheduler slice.
constexpr std::chrono::microseconds kWaitSpin{200};
// The spin of a team with more threads than the CPUs the process may run on (taskset, a cgroup's
// cpuset): there the awaited thread can only run when the waiting one gives the CPU up, and a
// 200 us spin before each wait cost 2.8x the one-thread step (2 threads on 1 CPU, the small glass
// drum: 690-702 us/step against 240; 3,923-3,986 without sleeping at all).
constexpr std::chrono::microseconds kShortSpin{5};

// The CPUs the calling thread may run on (its affinity mask, which the team's workers inherit
// when they are started); 0 if unknown.
int allowed_cpus() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) != 0) return 0;
  return CPU_COUNT(&set);
}

// Spins (plain loads, no PAUSE) until done(), for at most `spin`; then sleeps on `word` (futex)
// until done(), counted in `sleepers` so that the thread that makes done() true knows to wake
// it (notify_after below). Both sides use sequentially consistent operations on the word and
// the count: either the waker sees the sleeper counted, or the sleeper sees the word changed
// before it sleeps (a futex wait also returns at once when the word has changed).
template <class T, class Done>
void spin_then_sleep(std::atomic<T>& word, std::atomic<int>& sleepers, std::atomic<std::uint64_t>& sleeps,
                     std::chrono::microseconds spin, Done done) {
  const auto t0 = std::chrono::steady_clock::now();
  for (std::uint32_t k = 1;; ++k) {
    if (done()) return;
    if ((k & 255u) == 0 && std::chrono::steady_clock::now() - t0 > spin) break;
  }
  sleeps.fetch_add(1, std::memory_order_relaxed);
  sleepers.fetch_add(1, std::memory_order_seq_cst);
  for (T seen = word.load(std::memory_order_seq_cst); !done(); seen = word.load(std::memory_order_seq_cst))
    word.wait(seen, std::memory_order_seq_cst);
  sleepers.fetch_sub(1, std::memory_order_seq_cst);
}

// Wakes the threads asleep on `word` after the caller changed it (with a seq_cst operation).
template <class T>
void notify_after(std::atomic<T>& word, const std::atomic<int>& sleepers) {
  if (sleepers.load(std::memory_order_seq_cst) > 0) word.notify_all();
}
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
    struct Solo {  // (reset also when the job throws)
      Solo() { tl_solo = true; }
      ~Solo() { tl_solo = false; }
    } solo;
    const InJob in;
    job(0, 1);
    return;
  }
  const std::lock_guard<std::mutex> one_job_at_a_time(mutex_);  // callers on several threads queue
  while (static_cast<int>(workers_.size()) < n - 1) {
    const int me = static_cast<int>(workers_.size()) + 1;
    workers_.emplace_back([this, me] { worker_loop(me); });
    workers_.back().detach();
  }
  const int cpus = allowed_cpus();
  const std::chrono::microseconds spin = cpus > 0 && n > cpus ? kShortSpin : kWaitSpin;
  spin_us_.store(spin.count(), std::memory_order_relaxed);
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
    spin_then_sleep(finished_, finish_sleepers_, sleeps_, spin,
                    [&] { return finished_.load(std::memory_order_acquire) == n - 1; });
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
  const std::uint32_t g = barrier_gen_.load(std::memory_order_acquire);
  if (arrived_.fetch_add(1, std::memory_order_acq_rel) == n_ - 1) {
    arrived_.store(0, std::memory_order_relaxed);
    barrier_gen_.fetch_add(1, std::memory_order_seq_cst);
    notify_after(barrier_gen_, barrier_sleepers_);
    return;
  }
  const std::chrono::microseconds spin{spin_us_.load(std::memory_order_relaxed)};
  spin_then_sleep(barrier_gen_, barrier_sleepers_, sleeps_, spin,
                  [&] { return barrier_gen_.load(std::memory_order_acquire) != g; });
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
      if ((k & 1023u) == 0 &&
          std::chrono::steady_clock::now() - t0 > std::chrono::microseconds{spin_us_.load(std::memory_order_relaxed)}) {
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
      finished_.fetch_add(1, std::memory_order_seq_cst);
      notify_after(finished_, finish_sleepers_);
    }
  }
}

SpinTeam& team() {
  static SpinTeam* t = new SpinTeam;  // never destroyed: detached workers may still read it at exit
  return *t;
}

}  // namespace biodem
