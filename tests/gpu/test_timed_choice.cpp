// The timed choice's rules (gpu/timed_choice.hpp): which set runs at each run of steps, which
// sets are dropped after the first round, and which is chosen. Pure host code: the engine's
// timing on a device only supplies the times (tests/gpu/test_gpu_engine.cpp and
// tests/regression/test_gpu_runs.cpp run it inside the engine).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "gpu/timed_choice.hpp"

using biodem::gpu::KernelSet;
using biodem::gpu::TimedChoice;

namespace {

std::vector<KernelSet> sets(std::size_t n) {
  std::vector<KernelSet> v;
  for (std::size_t k = 0; k < n; ++k) v.push_back(KernelSet{.entries = k == 0, .single = k >= 2, .pack = k % 2 == 1});
  return v;
}

/// Runs the timing to its end with `time(set, run of that set)` as each run's time per step
/// (runs of 10 steps); returns the order in which the sets ran.
template <class T>
std::vector<std::size_t> run_to_end(TimedChoice& c, T time) {
  std::vector<std::size_t> ran, runs(c.sets().size(), 0);
  for (int guard = 0; c.under_way() && guard < 1000; ++guard) {
    const std::size_t s = c.current();
    ran.push_back(s);
    c.record(time(s, runs[s]++), 10);
  }
  return ran;
}

}  // namespace

// Five sets at 20, 30, 24, 25 and 25.1 us/step: the first round runs all five in order; 30 and
// 25.1 are more than 1.25 times 20 and are dropped; three more rounds run sets 0, 2 and 3; the
// median picks set 0. Steps: 5 + 3 x 3 runs of 10.
TEST(TimedChoice, FirstRoundDropsTheSetsAboveAQuarterOverTheFastest) {
  TimedChoice c;
  c.start(sets(5));
  ASSERT_TRUE(c.under_way());
  const double t[] = {20.0, 30.0, 24.0, 25.0, 25.1};  // (exact in binary: 1.25 x 20 is 25)
  const auto ran = run_to_end(c, [&](std::size_t s, std::size_t) { return t[s]; });
  const std::vector<std::size_t> expected = {0, 1, 2, 3, 4, 0, 2, 3, 0, 2, 3, 0, 2, 3};
  EXPECT_EQ(ran, expected);
  EXPECT_FALSE(c.under_way());
  EXPECT_EQ(c.choice(), 0u);
  EXPECT_EQ(c.current(), 0u);
  EXPECT_EQ(c.steps(), 140u);
  EXPECT_TRUE(c.kept(0));
  EXPECT_FALSE(c.kept(1));
  EXPECT_TRUE(c.kept(2));
  EXPECT_TRUE(c.kept(3));  // (exactly 1.25 times: kept)
  EXPECT_FALSE(c.kept(4));
  EXPECT_EQ(c.runs(1), 1u);
  EXPECT_EQ(c.runs(3), 4u);
  EXPECT_DOUBLE_EQ(c.median(1), 30.0);
  EXPECT_DOUBLE_EQ(c.median(3), 25.0);
}

// The choice is by the median of a set's runs: one slow run (a set slowed by something else)
// does not lose the set its place, and one fast run does not win it one. Set 0: 10, 10, 10, 30
// (median 10); set 1: 9 then 12 (median 12 of 9, 12, 12, 12); set 2: 10.5 each time.
TEST(TimedChoice, TheMedianOfTheRunsDecides) {
  TimedChoice c;
  c.start(sets(3));
  const auto ran = run_to_end(c, [](std::size_t s, std::size_t run) {
    if (s == 0) return run == 3 ? 30e-6 : 10e-6;
    if (s == 1) return run == 0 ? 9e-6 : 12e-6;
    return 10.5e-6;
  });
  EXPECT_EQ(ran.size(), 12u);  // (nothing dropped: all within 1.25 of 9)
  EXPECT_EQ(c.choice(), 0u);
  EXPECT_DOUBLE_EQ(c.median(0), 10e-6);
  EXPECT_DOUBLE_EQ(c.median(1), 12e-6);
  // Equal medians: the first in the candidates' order.
  c.start(sets(3));
  run_to_end(c, [](std::size_t s, std::size_t) { return s == 0 ? 11e-6 : 10e-6; });
  EXPECT_EQ(c.choice(), 1u);
}

// One set kept after the first round ends the timing there; one candidate needs no timing; a
// new start forgets the last timing.
TEST(TimedChoice, ASingleSetLeftEndsTheTiming) {
  TimedChoice c;
  c.start(sets(4));
  const auto ran = run_to_end(c, [](std::size_t s, std::size_t) { return s == 2 ? 10e-6 : 20e-6; });
  EXPECT_EQ(ran, (std::vector<std::size_t>{0, 1, 2, 3}));
  EXPECT_EQ(c.choice(), 2u);
  EXPECT_EQ(c.current_set(), sets(4)[2]);
  c.start(sets(1));
  EXPECT_FALSE(c.under_way());
  EXPECT_EQ(c.current(), 0u);
  EXPECT_EQ(c.steps(), 0u);
  EXPECT_TRUE(std::isnan(c.median(0)));
  c.record(1e-6, 10);  // (nothing under way: ignored)
  EXPECT_EQ(c.runs(0), 0u);
  c.start({});  // (no candidates: the default set, nothing timed)
  EXPECT_FALSE(c.under_way());
  EXPECT_EQ(c.sets().size(), 1u);
}

// A non-finite time in the first round (a timer that failed) drops nothing: every set goes on
// to the later rounds, and the choice is by the medians.
TEST(TimedChoice, ANonFiniteFirstRoundDropsNothing) {
  TimedChoice c;
  c.start(sets(3));
  const auto ran = run_to_end(c, [](std::size_t s, std::size_t run) {
    if (run == 0 && s == 1) return -std::numeric_limits<double>::infinity();
    return s == 2 ? 5e-6 : 50e-6;
  });
  EXPECT_EQ(ran.size(), 12u);
  EXPECT_EQ(c.choice(), 2u);
}
