// The timed choice of the GPU engine's contact kernels (docs/gpu.md, section 2, step 3): which
// sets it times, in what order, which it drops after their first run, and which it picks. Pure
// host code without the engine, so that the rules are tested on their own
// (tests/gpu/test_timed_choice.cpp); the engine (engine_impl.hpp) makes the candidate sets for
// its scene and times each run of steps between two list checks on the device.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace biodem::gpu {

/// One set of contact kernels. Every set gives the same bits (docs/gpu.md, section 2), so the
/// choice between them changes no result, only the time.
struct KernelSet {
  bool entries = false;     // per-contact kernels (PairEntries, then the per-sphere sums), else a row walk
  bool sum_lanes = false;   // (per-contact) the per-sphere sums by the row lanes
  bool single = false;      // (row walk) one thread per sphere, else the row lanes
  bool kick = false;        // (row walk) the body update inside the walk (ForcesKickDrift, ...Groups)
  bool pack = false;        // (row walk in one thread) the warp's touching contacts shared by its lanes
  std::uint8_t split = 0;   // (packed walk) 2^split lanes per sphere share its walk's tests
  bool body_lanes = false;  // (row walk apart from the body update, clumps) the body kernel by lanes
  friend bool operator==(const KernelSet&, const KernelSet&) = default;
};

/// Times the candidate sets in rounds and picks the fastest. Round 1 runs every set once; a set
/// whose time per step is more than kKeepWithin times the round's fastest is dropped then (a set
/// half again as slow costs its trial steps in every later round for nothing); the rounds after
/// it run the sets kept, kRounds in all; the choice is the kept set with the lowest median time
/// per step (the median, so that one run slowed by something else does not decide; ties: the
/// first in the candidates' order). A single kept set ends the timing at once.
class TimedChoice {
 public:
  static constexpr int kRounds = 4;
  static constexpr double kKeepWithin = 1.25;

  /// A new timing of `sets` (at least one).
  void start(std::vector<KernelSet> sets) {
    sets_ = std::move(sets);
    if (sets_.empty()) sets_.push_back(KernelSet{});
    samples_.assign(sets_.size(), {});
    kept_.assign(sets_.size(), true);
    order_.clear();
    for (std::size_t s = 0; s < sets_.size(); ++s) order_.push_back(s);
    round_ = 0;
    at_ = 0;
    steps_ = 0;
    choice_ = 0;
    under_way_ = sets_.size() > 1;
  }
  bool under_way() const { return under_way_; }
  /// The set that runs now: the one being timed, or the choice.
  std::size_t current() const { return under_way_ ? order_[at_] : choice_; }
  const KernelSet& current_set() const { return sets_[current()]; }
  /// The time per step of the run of `steps` steps of the current set, just measured.
  void record(double seconds_per_step, std::uint64_t steps) {
    if (!under_way_) return;
    samples_[order_[at_]].push_back(seconds_per_step);
    steps_ += steps;
    if (++at_ < order_.size()) return;
    at_ = 0;
    ++round_;
    if (round_ == 1) {
      double fastest = std::numeric_limits<double>::infinity();
      for (std::size_t s = 0; s < sets_.size(); ++s) fastest = std::min(fastest, samples_[s][0]);
      order_.clear();
      for (std::size_t s = 0; s < sets_.size(); ++s) {
        // (a non-finite time, or none at all, keeps every set: nothing to judge by)
        kept_[s] = !(samples_[s][0] > kKeepWithin * fastest) || !std::isfinite(fastest);
        if (kept_[s]) order_.push_back(s);
      }
    }
    if (round_ < kRounds && order_.size() > 1) return;
    under_way_ = false;
    choice_ = order_.front();
    for (std::size_t s : order_)
      if (median(s) < median(choice_)) choice_ = s;
  }

  const std::vector<KernelSet>& sets() const { return sets_; }
  std::size_t choice() const { return choice_; }
  /// Kept after the first round (true before it ends).
  bool kept(std::size_t s) const { return kept_[s]; }
  /// The runs of set s timed so far.
  std::size_t runs(std::size_t s) const { return samples_[s].size(); }
  /// The median time per step of set s's runs (NaN before its first).
  double median(std::size_t s) const {
    std::vector<double> t = samples_[s];
    if (t.empty()) return std::numeric_limits<double>::quiet_NaN();
    std::sort(t.begin(), t.end());
    return t.size() % 2 ? t[t.size() / 2] : 0.5 * (t[t.size() / 2 - 1] + t[t.size() / 2]);
  }
  /// Steps timed since the start.
  std::uint64_t steps() const { return steps_; }

 private:
  std::vector<KernelSet> sets_{KernelSet{}};
  std::vector<std::vector<double>> samples_{std::vector<double>{}};
  std::vector<bool> kept_{true};
  std::vector<std::size_t> order_{0};  // the sets of this round, in the candidates' order
  std::size_t at_ = 0;                 // the place in order_ of the set that runs now
  int round_ = 0;
  std::uint64_t steps_ = 0;
  std::size_t choice_ = 0;
  bool under_way_ = false;
};

}  // namespace biodem::gpu
