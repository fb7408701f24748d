// The step's thread team (core/spin_team.hpp): jobs, barriers, and for_each_index, which runs the
// list build's and the wall candidates' loops on the team instead of OpenMP.
#include <gtest/gtest.h>

#include <sched.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include "core/spin_team.hpp"

using namespace biodem;

// Every index exactly once, for team sizes above, at and below the count, and for empty loops.
TEST(SpinTeam, ForEachIndexVisitsEveryIndexOnce) {
  for (int threads : {1, 2, 3, 4}) {
    for (std::size_t count : {std::size_t{0}, std::size_t{1}, std::size_t{3}, std::size_t{1000}}) {
      std::vector<std::atomic<int>> hits(count);
      for_each_index(threads, count, [&](std::size_t k) { hits[k].fetch_add(1, std::memory_order_relaxed); });
      int wrong = 0;
      for (const auto& h : hits) wrong += h.load() != 1;
      EXPECT_EQ(wrong, 0) << threads << " threads, " << count << " indices";
    }
  }
}

// With several threads the work is shared: a loop whose items wait for each other can only end
// if two threads run it at once (one thread would wait forever; the test gives up after 10 s).
TEST(SpinTeam, ForEachIndexRunsOnSeveralThreads) {
  std::atomic<int> started{0};
  std::atomic<bool> gave_up{false};
  for_each_index(2, 2, [&](std::size_t) {
    started.fetch_add(1);
    const auto t0 = std::chrono::steady_clock::now();
    while (started.load() < 2) {
      if (std::chrono::steady_clock::now() - t0 > std::chrono::seconds(10)) {
        gave_up = true;
        return;
      }
    }
  });
  EXPECT_FALSE(gave_up.load()) << "the two items did not run at the same time";
}

// Inside a job of the team, for_each_index runs on the calling thread (jobs do not nest; a
// nested run() would wait for the mutex its own job holds).
TEST(SpinTeam, ForEachIndexInsideAJobRunsOnTheCallingThread) {
  std::vector<std::atomic<int>> foreign(2);
  std::vector<std::atomic<int>> hits(2 * 50);
  team().run(2, [&](int me, int) {
    const auto self = std::this_thread::get_id();
    for_each_index(2, 50, [&](std::size_t k) {
      if (std::this_thread::get_id() != self) foreign[me].fetch_add(1);
      hits[static_cast<std::size_t>(me) * 50 + k].fetch_add(1);
    });
  });
  EXPECT_EQ(foreign[0].load() + foreign[1].load(), 0);
  int wrong = 0;
  for (const auto& h : hits) wrong += h.load() != 1;
  EXPECT_EQ(wrong, 0);
  EXPECT_FALSE(SpinTeam::in_job());
}

namespace {
// `rounds` rounds of one job of `threads` threads: each writes the round number, a barrier, each
// reads every thread's number, a barrier. Returns how many reads saw another round's number.
int barrier_round_errors(int threads, int rounds) {
  std::vector<std::atomic<int>> value(static_cast<std::size_t>(threads));
  std::atomic<int> errors{0};
  team().run(threads, [&](int me, int n) {
    for (int r = 1; r <= rounds; ++r) {
      value[me].store(r, std::memory_order_relaxed);
      team().barrier();
      for (int t = 0; t < n; ++t)
        if (value[t].load(std::memory_order_relaxed) != r) errors.fetch_add(1);
      team().barrier();
    }
  });
  return errors.load();
}
}  // namespace

// A barrier holds every thread until all have arrived: what each wrote before it is seen by all
// after it, over many rounds.
TEST(SpinTeam, BarrierSeparatesRounds) { EXPECT_EQ(barrier_round_errors(3, 50), 0); }

// A thread held up past the team's spin (2 ms here, against 200 us) finds the others asleep at
// the barrier or at the end of the job; they are woken when it arrives, over many rounds, and
// what each wrote before the barrier is seen by all after it.
TEST(SpinTeam, ThreadsAsleepAtABarrierOrAtTheJobEndAreWoken) {
  constexpr int kThreads = 3, kRounds = 12;
  const std::uint64_t sleeps_before = team().sleeps();
  std::vector<std::atomic<int>> value(kThreads);
  std::atomic<int> errors{0};
  std::atomic<int> last_done{0};
  for (int job = 0; job < 4; ++job) {
    team().run(kThreads, [&](int me, int n) {
      for (int r = 1; r <= kRounds; ++r) {
        if (me == r % n) std::this_thread::sleep_for(std::chrono::milliseconds(2));
        value[me].store(r + 100 * job, std::memory_order_relaxed);
        team().barrier();
        for (int t = 0; t < n; ++t)
          if (value[t].load(std::memory_order_relaxed) != r + 100 * job) errors.fetch_add(1);
        team().barrier();
      }
      // A worker still busy long after the caller's share ended: run() returns after it.
      if (me == n - 1) {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        last_done.store(job + 1, std::memory_order_relaxed);
      }
    });
    EXPECT_EQ(last_done.load(), job + 1) << "run() returned before a worker ended its share";
  }
  EXPECT_EQ(errors.load(), 0);
  // Every round left two threads waiting 2 ms at a barrier, and every job the caller at its end.
  EXPECT_GE(team().sleeps() - sleeps_before, static_cast<std::uint64_t>(4 * kRounds));
}

// A team larger than the CPUs its caller may use (here 3 threads on one CPU, as under taskset or
// a cgroup's cpuset) spins 5 us instead of 200 before sleeping: there the awaited thread can only
// run once the waiting one gives the CPU up. Its barriers and job ends still hold.
TEST(SpinTeam, ATeamLargerThanItsCpusSpinsBriefly) {
  team().run(3, [](int, int) {});  // (the workers exist before the pinning: they keep their own mask)
  cpu_set_t before;
  CPU_ZERO(&before);
  ASSERT_EQ(sched_getaffinity(0, sizeof before, &before), 0);
  cpu_set_t one;
  CPU_ZERO(&one);
  for (int c = 0; c < CPU_SETSIZE; ++c)
    if (CPU_ISSET(c, &before)) {
      CPU_SET(c, &one);
      break;
    }
  ASSERT_EQ(sched_setaffinity(0, sizeof one, &one), 0);  // the calling thread only
  constexpr int kThreads = 3;
  const int errors = barrier_round_errors(kThreads, 200);
  const auto spin_on_one_cpu = team().spin_us();
  ASSERT_EQ(sched_setaffinity(0, sizeof before, &before), 0);
  EXPECT_EQ(errors, 0);
  EXPECT_EQ(spin_on_one_cpu, 5);
  if (CPU_COUNT(&before) >= kThreads) {
    team().run(kThreads, [](int, int) {});
    EXPECT_EQ(team().spin_us(), 200);
  }
}
