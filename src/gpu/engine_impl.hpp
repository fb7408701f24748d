// The GPU engine's host side, written once over a Thrust system: included by
// device_engine_cuda.cu (Thrust's CUDA system, compiled by nvcc) and by
// device_engine_host.cpp (Thrust's OpenMP system, compiled by g++), each with its own
// BIODEM_GPU_NS and System policy. See device_engine.hpp for the design.
#pragma once
#include <thrust/binary_search.h>
#include <thrust/copy.h>
#include <thrust/count.h>
#include <thrust/for_each.h>
#include <thrust/functional.h>
#include <thrust/gather.h>
#include <thrust/iterator/counting_iterator.h>
#include <thrust/iterator/transform_iterator.h>
#include <thrust/reduce.h>
#include <thrust/scan.h>
#include <thrust/transform_scan.h>
#include <thrust/fill.h>
#include <thrust/scatter.h>
#include <thrust/sequence.h>
#include <thrust/sort.h>
#include <thrust/transform_reduce.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <numeric>
#include <string>
#include <type_traits>
#include <vector>

#include "core/error.hpp"
#include "gpu/device_engine.hpp"
#include "gpu/graph_key.hpp"
#include "gpu/kernels.hpp"
#include "gpu/timed_choice.hpp"
#include "neighbor/skin.hpp"

namespace biodem::gpu::BIODEM_GPU_NS {

template <class T>
T* raw(typename System::template vector<T>& v) {
  return thrust::raw_pointer_cast(v.data());
}

template <class D, class H>
void to_device(D& d, const H& h) {
  if (h.empty()) {  // Thrust would take &*begin() of an empty range (a null reference)
    d.clear();
    return;
  }
  d.assign(h.begin(), h.end());
}
template <class H, class D>
void to_host(H& h, const D& d) {
  h.resize(d.size());
  if (!d.empty()) thrust::copy(d.begin(), d.end(), h.begin());
}

/// Bodies are sorted by cell at the list build of every upload and at every kSortEvery-th build
/// after it (docs/gpu.md, "Bodies sorted by cell"; BIODEM_GPU_SORT overrides). Measured
/// emulated on the quick drums: one build interval puts 0.3-3 % of adjacent slots out of cell
/// order; every 4th build keeps that at 0.8-6 % for a quarter of the sorting.
inline constexpr std::uint32_t kSortEvery = 4;
/// On CPU threads (where BIODEM_GPU_FORCES=auto does not time the kernels, Tuning), below this
/// many spheres the pair and wall contacts run as one thread per entry (PairEntries, SumEntries),
/// from it one thread per sphere (Forces). From the H100 figures of 2026-11-26 (docs/gpu.md
/// section 4), taken with earlier versions of the entry kernels: entries 24.4 vs rows 33.2
/// us/step at 4,948 spheres, 50.7 vs 47.8 at 19,791, 44.5 vs 37.0 at 39,366. On a GPU the two
/// sets are timed instead.
inline constexpr std::uint32_t kEntryForcesBelow = 15000;

class Engine final : public DeviceEngine {
 public:
  template <class T>
  using vec = typename System::template vector<T>;

  Engine(sim::Simulation& host, std::string name) : host_(host), name_(std::move(name)) {
    // Switches for tests and comparisons (docs/gpu.md): BIODEM_GPU_FUSE=0 launches ReduceKick
    // and KickDriftSpheres separately between list checks.
    if (const char* fuse = std::getenv("BIODEM_GPU_FUSE"); fuse && *fuse) {
      if (std::string(fuse) != "0" && std::string(fuse) != "1")
        throw Error("BIODEM_GPU_FUSE = '" + std::string(fuse) + "': expected 0 or 1");
      fuse_ = std::string(fuse) == "1";
    }
    // BIODEM_GPU_LIST_GUARD=0: no list guard (StepFlags): a sphere past half the skin is found at
    // the list checks only, and stops the run where the list may have given forces past it (the
    // rule before 2026-11-28); for comparisons of speed.
    if (const char* guard = std::getenv("BIODEM_GPU_LIST_GUARD"); guard && *guard) {
      if (std::string(guard) != "0" && std::string(guard) != "1")
        throw Error("BIODEM_GPU_LIST_GUARD = '" + std::string(guard) + "': expected 0 or 1");
      guard_on_ = std::string(guard) == "1";
    }
    // BIODEM_GPU_SORT=N: bodies sorted by cell at the list build of every upload and at every
    // N-th build after it; 0: never (the host's order throughout).
    if (const char* sort = std::getenv("BIODEM_GPU_SORT"); sort && *sort) {
      char* end = nullptr;
      const unsigned long v = std::strtoul(sort, &end, 10);
      if (*end != '\0' || *sort == '-')
        throw Error("BIODEM_GPU_SORT = '" + std::string(sort) + "': expected a whole number of list builds (0: never)");
      sort_every_ = static_cast<std::uint32_t>(std::min<unsigned long>(v, 1u << 30));
    }
    // BIODEM_GPU_FORCES=entries|rows|timed|auto: the entry kernels (PairEntries, SumEntries),
    // one thread per sphere walking its row (Forces), the faster of the two as timed over the
    // first steps after each upload (Tuning), or auto: timed on a GPU, by the sphere count
    // (kEntryForcesBelow) on CPU threads. The same bits whichever runs.
    if (const char* forces = std::getenv("BIODEM_GPU_FORCES"); forces && *forces) {
      const std::string v(forces);
      if (v != "rows" && v != "entries" && v != "timed" && v != "auto")
        throw Error("BIODEM_GPU_FORCES = '" + v + "': expected entries, rows, timed or auto");
      forces_mode_ = v == "entries" ? ForcesMode::entries
                     : v == "rows"  ? ForcesMode::rows
                     : v == "timed" ? ForcesMode::timed
                                    : ForcesMode::automatic;
    }
    // BIODEM_GPU_SKIN_DIAMETERS=F (0 < F <= 2): the device list's skin is F times the smallest
    // sphere diameter instead of the case's skin (fewer rebuilds for longer rows; for sweeps:
    // results do not depend on the skin, but the skin is part of the state a download hands
    // back, so checkpoints then differ in it).
    if (const char* skin = std::getenv("BIODEM_GPU_SKIN_DIAMETERS"); skin && *skin) {
      char* end = nullptr;
      const double v = std::strtod(skin, &end);
      if (*end != '\0' || !(v > 0.0 && v <= 2.0))
        throw Error("BIODEM_GPU_SKIN_DIAMETERS = '" + std::string(skin) + "': expected a number above 0 and at most 2");
      skin_diameters_ = v;
    }
    // BIODEM_GPU_CHECK_EVERY=N (1 to 64): at most N steps between two list checks (default 10;
    // fewer when spheres move fast). Results do not depend on it (docs/gpu.md, section 4).
    if (const char* every = std::getenv("BIODEM_GPU_CHECK_EVERY"); every && *every) {
      char* end = nullptr;
      const unsigned long v = std::strtoul(every, &end, 10);
      if (*end != '\0' || *every == '-' || v < 1 || v > 64)
        throw Error("BIODEM_GPU_CHECK_EVERY = '" + std::string(every) + "': expected a whole number of steps from 1 to 64");
      check_every_ = static_cast<std::uint32_t>(v);
    }
    // BIODEM_GPU_SUM_LANES=1|0|auto: the entry kernels' per-sphere sums as a row walk shared by
    // the row lanes (SumEntriesWalk, SumEntriesKickDriftWalk), or by one thread per sphere
    // (SumEntries, SumEntriesKickDrift); auto: a fourth set of the timed choice on a GPU, one
    // thread elsewhere. The same bits either way.
    if (const char* sl = std::getenv("BIODEM_GPU_SUM_LANES"); sl && *sl) {
      const std::string v(sl);
      if (v != "0" && v != "1" && v != "auto")
        throw Error("BIODEM_GPU_SUM_LANES = '" + v + "': expected 0, 1 or auto");
      sum_lanes_mode_ = v == "1" ? SumLanes::on : v == "0" ? SumLanes::off : SumLanes::automatic;
    }
    // BIODEM_GPU_WALK_KICK=1|0|auto: the row walk and the body update in one kernel (single-sphere
    // bodies: ForcesKickDrift; clumps of up to 32 spheres: ForcesKickDriftGroups, a group of lanes
    // per body; the sphere motion in two buffers), or apart (Forces, ReduceKickDrift); auto: timed
    // sets of both kinds on a GPU (the timed choice), apart elsewhere. The same bits either way.
    if (const char* wk = std::getenv("BIODEM_GPU_WALK_KICK"); wk && *wk) {
      const std::string v(wk);
      if (v != "0" && v != "1" && v != "auto")
        throw Error("BIODEM_GPU_WALK_KICK = '" + v + "': expected 0, 1 or auto");
      walk_kick_mode_ = v == "1" ? WalkKick::on : v == "0" ? WalkKick::off : WalkKick::automatic;
    }
    // BIODEM_GPU_SUMS=ordered|fixed: each sphere's contact sums in the row order as doubles (the
    // default; every kernel set above gives the same bits), or as 64-bit fixed-point integers
    // added in any order (the order-free family; its own bits, the same on any number of threads;
    // fixed_sums.hpp): its sets, the per-contact kernels (PairEntriesFixed, then the body
    // kernels) and the row walk (ForcesFixed, in one thread or by the row lanes), give the same
    // bits, so BIODEM_GPU_FORCES chooses between them as between the ordered sets. It has no set
    // with the entry sums by the row lanes or with the body update in the walk.
    if (const char* sums = std::getenv("BIODEM_GPU_SUMS"); sums && *sums) {
      const std::string v(sums);
      if (v != "ordered" && v != "fixed") throw Error("BIODEM_GPU_SUMS = '" + v + "': expected ordered or fixed");
      fixed_sums_ = v == "fixed";
      if (fixed_sums_) {
        for (const char* other : {"BIODEM_GPU_SUM_LANES", "BIODEM_GPU_WALK_KICK"})
          if (const char* o = std::getenv(other); o && *o && std::string(o) == "1")
            throw Error("BIODEM_GPU_SUMS = 'fixed' has no kernel set for " + std::string(other) + " = '1'");
        sum_lanes_mode_ = SumLanes::off;
        walk_kick_mode_ = WalkKick::off;
      }
    }
    // BIODEM_GPU_PAIR_LIST=compact|full: the per-contact passes over a list of the pairs'
    // lower-id entries made at each list build (the default), or over every row entry and wall
    // slot (most of whose threads do nothing). The same bits either way.
    if (const char* pl = std::getenv("BIODEM_GPU_PAIR_LIST"); pl && *pl) {
      const std::string v(pl);
      if (v != "compact" && v != "full") throw Error("BIODEM_GPU_PAIR_LIST = '" + v + "': expected compact or full");
      compact_pairs_ = v == "compact";
    }
    // BIODEM_GPU_RECORDS=1: the contact kernels read each sphere from one 96-byte record
    // (SphereRecord, kept beside the arrays) instead of six arrays; BIODEM_GPU_OWN_SPHERE=1: the
    // row walk by one thread loads its own sphere once per row (Forces::walk_heads<true>). The same bits
    // either way; both off by default until timed on a GPU (docs/gpu.md, section 4).
    for (const auto& [name, flag] : {std::pair<const char*, bool*>{"BIODEM_GPU_RECORDS", &records_},
                                     std::pair<const char*, bool*>{"BIODEM_GPU_OWN_SPHERE", &own_sphere_}})
      if (const char* v = std::getenv(name); v && *v) {
        if (std::string(v) != "0" && std::string(v) != "1")
          throw Error(std::string(name) + " = '" + v + "': expected 0 or 1");
        *flag = std::string(v) == "1";
#ifdef BIODEM_GPU_NO_RECORD_PATHS
        if (*flag) throw Error(std::string(name) + " = '1': this biodem was built without it (-DBIODEM_GPU_NO_RECORD_PATHS)");
#endif
      }
    // BIODEM_GPU_WALK_PACK=1|0: where one thread walks each row (Forces, ForcesKickDrift,
    // ForcesKickDriftGroups), the walks of a warp's spheres share their touching contacts across
    // its lanes (walk_packed), or not; unset: timed sets of both kinds (the timed choice), not
    // shared elsewhere. The same bits either way (docs/gpu.md, section 2).
    if (const char* v = std::getenv("BIODEM_GPU_WALK_PACK"); v && *v) {
      if (std::string(v) != "0" && std::string(v) != "1")
        throw Error(std::string("BIODEM_GPU_WALK_PACK = '") + v + "': expected 0 or 1");
      walk_pack_mode_ = std::string(v) == "1" ? WalkPack::on : WalkPack::off;
    }
    // BIODEM_GPU_PACK_SPLIT=1|2|4: the lanes of a warp that share each sphere's packed walk
    // (walk_packed's split; on CUDA, not for the clumps' walk with the body update by groups);
    // unset: the timed choice's packed sets with one, two and (where four threads per sphere fit
    // in one wave of the device) four. The same bits either way.
    if (const char* v = std::getenv("BIODEM_GPU_PACK_SPLIT"); v && *v) {
      const std::string sv(v);
      if (sv != "1" && sv != "2" && sv != "4")
        throw Error("BIODEM_GPU_PACK_SPLIT = '" + sv + "': expected 1, 2 or 4 lanes per sphere");
      pack_split_forced_ = true;
      pack_split_log2_ = sv == "1" ? 0u : sv == "2" ? 1u : 2u;
    }
    // BIODEM_GPU_BODY_LANES=1|2|4|8|16|32|auto: in scenes of clumps, the fused body kernel by one
    // thread per body (ReduceKickDrift) or by a group of that many lanes (ReduceKickDriftLanes;
    // auto: the most spheres of a body, rounded up to a power of two, at most 32). Unset: timed
    // sets of both kinds (the timed choice, with the lanes of auto), one thread elsewhere. On CPU
    // threads always one lane. The same bits either way.
    if (const char* bl = std::getenv("BIODEM_GPU_BODY_LANES"); bl && *bl) {
      const std::string v(bl);
      body_lanes_forced_ = true;
      if (v == "auto") {
        body_lanes_auto_ = true;
      } else {
        std::uint32_t log2 = 0;
        while (log2 <= 5 && std::to_string(1u << log2) != v) ++log2;
        if (log2 > 5) throw Error("BIODEM_GPU_BODY_LANES = '" + v + "': expected 1, 2, 4, 8, 16, 32 or auto");
        body_lanes_log2_ = log2;
      }
    }
    // BIODEM_GPU_QUEUED_CHECK=0: every list check reduces and waits (instead of reading the
    // reduction queued before it; for comparisons, and a way out if the queued one fails).
    if (const char* q = std::getenv("BIODEM_GPU_QUEUED_CHECK"); q && *q) {
      if (std::string(q) != "0" && std::string(q) != "1")
        throw Error("BIODEM_GPU_QUEUED_CHECK = '" + std::string(q) + "': expected 0 or 1");
      queued_checks_ = std::string(q) == "1";
    }
    // Test hook BIODEM_TEST_GPU_FAULT_AT_STEP=N: once the run reaches step N, a kernel faults
    // (System::inject_fault; on CUDA it breaks the context), so that gpu_check sees a device
    // fault end the run with one line, not std::terminate (docs/gpu.md, Errors).
    if (const char* f = std::getenv("BIODEM_TEST_GPU_FAULT_AT_STEP"); f && *f) {
      char* end = nullptr;
      const unsigned long long v = std::strtoull(f, &end, 10);
      if (*end != '\0' || *f == '-' || v == 0)
        throw Error("BIODEM_TEST_GPU_FAULT_AT_STEP = '" + std::string(f) + "': expected a step number above 0");
      fault_at_step_ = v;
    }
    // BIODEM_TEST_GPU_FAULT_IN_THRUST=1: the injected fault is met first inside a Thrust
    // reduction (on CUDA: thrust::system_error, which the engine names as its own CUDA errors);
    // without it, at the next queued read, wait or download. On CPU threads the same as without.
    if (const char* f = std::getenv("BIODEM_TEST_GPU_FAULT_IN_THRUST"); f && *f) {
      if (std::string(f) != "0" && std::string(f) != "1")
        throw Error("BIODEM_TEST_GPU_FAULT_IN_THRUST = '" + std::string(f) + "': expected 0 or 1");
      fault_in_thrust_ = std::string(f) == "1";
    }
    // BIODEM_GPU_PROFILE=1: where the wall time of advance() goes (profile_report(), run.log).
    if (const char* prof = std::getenv("BIODEM_GPU_PROFILE"); prof && *prof) {
      if (std::string(prof) != "0" && std::string(prof) != "1")
        throw Error("BIODEM_GPU_PROFILE = '" + std::string(prof) + "': expected 0 or 1");
      profile_.on = std::string(prof) == "1";
    }
  }

  std::string device_name() const override { return name_; }
  std::uint64_t list_builds() const override { return builds_; }
  std::uint64_t row_widenings() const override { return widenings_; }
  std::uint32_t row_capacity() const override { return rows_.cap; }
  std::uint64_t fused_steps() const override { return fused_units_; }
  std::uint64_t sums_in_kick_steps() const override { return summed_in_kick_; }
  std::uint64_t waitless_list_checks() const override { return waitless_checks_; }
  std::uint64_t guard_stops() const override { return guard_halts_; }
  std::uint64_t removal_tests() const override { return sink_tests_; }
  std::uint64_t removal_uploads() const override { return sink_removals_; }
  std::uint64_t graph_runs() const override { return graph_runs_; }
  std::uint64_t plain_runs() const override { return plain_runs_; }
  void set_grouped_list_build(bool on) override { grouped_build_ = on; }
  std::uint64_t grouped_list_builds() const override { return grouped_builds_; }
  std::string list_build_kernel() const override {
    return !grouped_build_ ? "one thread per sphere (BuildRows)"
           : std::string("BuildRowsGrouped with ") + System::build_lanes() + " (rows up to " +
                 std::to_string(kGroupRowCap) + " wide; wider rows one thread per sphere)";
  }
  void set_sort_every(std::uint32_t builds) override {
    sort_every_ = builds;
    builds_until_sort_ = builds ? 1 : 0;  // at the next build
  }
  std::uint64_t body_sorts() const override { return sorts_; }
  std::vector<std::uint32_t> body_order() override {
    std::vector<std::uint32_t> h;
    to_host(h, b_host_);
    return h;
  }
  void set_fused_kick(bool on) override {
    invalidate_graphs();
    fuse_ = on;
  }
  void set_sum_lanes(bool on) override {
    sum_lanes_mode_ = on ? SumLanes::on : SumLanes::off;
    invalidate_graphs();
    if (timed_choice()) restart_tuning();  // (the candidate sets change)
  }
  void set_walk_kick(bool on) override {
    walk_kick_mode_ = on ? WalkKick::on : WalkKick::off;
    invalidate_graphs();
    if (timed_choice()) restart_tuning();
  }
  std::uint64_t walk_kick_steps() const override { return walk_kick_units_; }
  void set_entry_forces(bool on) override {
    invalidate_graphs();
    if (rows_.length.size() == ns() && rows_.mirror.size() == rows_.j.size()) mirror_history();
    forces_mode_ = on ? ForcesMode::entries : ForcesMode::rows;
  }
  std::uint64_t entry_force_passes() const override { return entry_passes_; }
  void set_fixed_sums(bool on) override {
    invalidate_graphs();
    if (on && !fixed_sums_) {
      sum_lanes_mode_ = SumLanes::off;
      walk_kick_mode_ = WalkKick::off;
    }
    fixed_sums_ = on;
    if (timed_choice()) restart_tuning(false);  // (the candidate sets change; buffers below)
    if (on && !fixed_caps_set_) fixed_grid();
    if (on && rows_.length.size() == ns()) {
      ensure_fixed_sums();
      ensure_entry_buffers();
    }
  }
  bool fixed_sums() const override { return fixed_sums_; }
  double fixed_force_quantum() const override { return fixed_sums_ ? 1.0 / fixed_force_scale_ : 0.0; }
  double fixed_torque_quantum() const override { return fixed_sums_ ? 1.0 / fixed_torque_scale_ : 0.0; }
  void set_fixed_caps(double force_cap_n, double torque_cap_n_m) override {
    fixed_force_scale_ = fixed::scale_for(force_cap_n);
    fixed_torque_scale_ = fixed::scale_for(torque_cap_n_m);
    fixed_caps_set_ = true;
    invalidate_graphs();
  }
  std::uint64_t fixed_sum_passes() const override { return fixed_passes_; }
  std::int64_t listed_pairs() override {
    if (!compact_pairs_) return -1;
    std::vector<std::uint32_t> c;
    to_host(c, pair_count_);
    return c.empty() ? 0 : c[0];
  }
  std::int64_t listed_wall_slots() override {
    if (!compact_pairs_) return -1;
    std::vector<std::uint32_t> c;
    to_host(c, wall_count_);
    return c.empty() ? 0 : c[0];
  }
  std::string profile_report() const override;
  std::string contact_kernels() const override {
    std::string fixed_note;
    if (fixed_sums_) {
      char q[96];
      std::snprintf(q, sizeof q, "quanta %.3g N and %.3g N m", 1.0 / fixed_force_scale_, 1.0 / fixed_torque_scale_);
      fixed_note = std::string(" with fixed-point sums in any order (BIODEM_GPU_SUMS=fixed, the family of a resumed checkpoint or a test; ") + q + ")";
    }
    const std::string set = fixed_sums_ ? (use_entry_kernels() ? "per-contact (PairEntriesFixed)" + fixed_note
                                                               : "per-sphere row walk (ForcesFixed)" + fixed_note)
                          : use_entry_kernels() ? std::string("per-contact (PairEntries, SumEntries") +
                                                      (sum_lanes() ? " by the " + System::walk_lanes() + ")" : ")")
                                                : walk_kick() ? (single_spheres_ ? std::string("per-sphere row walk with the body update (ForcesKickDrift)")
                                                                                 : "per-sphere row walk with the body update in groups of " +
                                                                                       std::to_string(1u << walk_kick_lanes_log2_) +
                                                                                       " lanes per body (ForcesKickDriftGroups; on CPU threads one lane)")
                                                              : "per-sphere row walk (Forces)";
    return contact_set(set) + loads_note();
  }
  /// How the contact kernels load the spheres, when not as by default.
  std::string loads_note() const {
    std::string r;
    if (records_) r += "; each sphere read from its record (BIODEM_GPU_RECORDS=1)";
    if (own_sphere_)
      r += use_entry_kernels() ? "; BIODEM_GPU_OWN_SPHERE=1 unused (no row walk)"
           : walk_pack() ? "; BIODEM_GPU_OWN_SPHERE=1 unused (the walks sharing their touching contacts load both spheres per entry)"
           : walk_kick() && !single_spheres_
               ? "; BIODEM_GPU_OWN_SPHERE=1 unused (the clumps' walk with the body update loads both spheres per entry)"
               : "; the row walk, where one thread walks a row, holds its own sphere (BIODEM_GPU_OWN_SPHERE=1)";
    if (walk_pack_mode_ == WalkPack::on && (use_entry_kernels() || fixed_sums_))
      r += "; BIODEM_GPU_WALK_PACK=1 unused (no ordered row walk)";
    else if (walk_pack())
      r += std::string("; where one thread walks a row, the walks of a warp share their touching contacts across its lanes") +
           (pack_split() ? ", " + std::to_string(1u << pack_split()) + " lanes per sphere" : std::string()) + " (" +
           (walk_pack_mode_ == WalkPack::on ? "BIODEM_GPU_WALK_PACK=1" : "the timed choice") +
           (pack_split_forced_ && pack_split() ? ", BIODEM_GPU_PACK_SPLIT" : "") + "; on CPU threads one lane)";
    if (pack_split_forced_ && pack_split_log2_ && walk_pack() && walk_kick() && !single_spheres_)
      r += "; BIODEM_GPU_PACK_SPLIT unused (the clumps' walk with the body update has its own groups of lanes)";
    else if (pack_split_forced_ && pack_split_log2_ && !pack_split())
      r += "; BIODEM_GPU_PACK_SPLIT unused (no row walk in one thread sharing its touching contacts: "
           "BIODEM_GPU_WALK_PACK=1 and the walk in one thread)";
    if (walk_kick_mode_ == WalkKick::on && !walk_kick_fits())
      r += "; BIODEM_GPU_WALK_KICK=1 unused (a body of more than 32 spheres: no kernel for it)";
    if (body_lanes() && fixed_sums_)
      r += "; BIODEM_GPU_BODY_LANES unused (the order-free family has its own body kernel)";
    else if (body_lanes() && walk_kick())
      r += "; BIODEM_GPU_BODY_LANES unused (the walk with the body update has its own groups of lanes)";
    else if (body_lanes())
      r += "; the clumps' body kernel between list checks by " + std::to_string(1u << body_lanes()) + " lanes per body (" +
           (body_lanes_forced_ ? std::string("BIODEM_GPU_BODY_LANES") + (body_lanes_auto_ ? "=auto" : "")
                               : std::string("the timed choice")) +
           "; on CPU threads one)";
    return r;
  }
  std::string contact_set(const std::string& set) const {
    auto us = [](double seconds) {
      char b[32];
      std::snprintf(b, sizeof b, "%.2f", 1e6 * seconds);
      return std::string(b);
    };
    switch (forces_mode_) {
      case ForcesMode::entries: return set + ", set by BIODEM_GPU_FORCES=entries or a test";
      case ForcesMode::rows: return set + ", set by BIODEM_GPU_FORCES=rows or a test";
      default: break;
    }
    if (!timed_choice())
      return set + ", by the sphere count (" + (use_entry_kernels() ? "below " : "at least ") +
             std::to_string(kEntryForcesBelow) + ")";
    if (tuning_under_way())
      return set + " for now: the timing of the sets is under way (" + std::to_string(choices_) +
             " choice(s) in the run so far)";
    const auto& sets = tuning_.sets();
    char keep[16];
    std::snprintf(keep, sizeof keep, "%.2f", TimedChoice::kKeepWithin);
    double entries = std::numeric_limits<double>::infinity(), walk = entries;
    std::string each;
    for (std::size_t k = 0; k < sets.size(); ++k) {
      const double t = tuning_.median(k);
      if (!(t >= 0.0)) continue;  // (not timed)
      (sets[k].entries ? entries : walk) = std::min(sets[k].entries ? entries : walk, t);
      each += std::string(each.empty() ? "" : "; ") + set_name(sets[k]) + ": " + us(t) + " us/step" +
              (k == tuning_.choice() ? " (chosen)"
               : !tuning_.kept(k) ? " (dropped after one run)"
                                  : "");
    }
    auto us_or_none = [&us](double t) { return std::isfinite(t) ? us(t) + " us/step" : std::string("none"); };
    return set + (use_entry_kernels() ? std::string() : ", " + set_name(tuned_set())) +
           ", the fastest when the sets were last timed, over " + std::to_string(tuning_.steps()) +
           " steps (median of up to " + std::to_string(TimedChoice::kRounds) + " runs each; a set above " + keep +
           " times the first round's fastest dropped after its run in it): per-contact " + us_or_none(entries) +
           ", row walk " + us_or_none(walk) + "; each set: [" + each +
           "] (" + std::to_string(choices_) + " choice(s) in the run: after each upload, at each phase start and every " +
           std::to_string(retime_every_) + " steps)";
  }
  /// A set of the timed choice as run.log names it.
  std::string set_name(const KernelSet& k) const {
    if (k.entries) return std::string("per-contact") + (k.sum_lanes ? " with the sums by the " + System::walk_lanes() : "");
    std::string r = std::string("row walk ") + (k.single ? "in one thread per sphere" : "with " + System::walk_lanes());
    if (k.kick)
      r += single_spheres_ ? " with the body update"
                           : " with the body update in groups of " + std::to_string(1u << walk_kick_lanes_log2_) +
                                 " lanes per body";
    if (k.pack) r += ", touching contacts shared across the warp";
    if (k.pack && (k.split || (pack_split_forced_ && pack_split_log2_ && (single_spheres_ || !k.kick))))
      r += " by " + std::to_string(1u << (k.split ? k.split : pack_split_log2_)) + " lanes per sphere";
    if (k.body_lanes)
      r += ", the body kernel by " + std::to_string(1u << (body_lanes_forced_ ? body_lanes_log2_ : body_lanes_auto_log2_)) +
           " lanes per body";
    return r;
  }
  std::vector<std::pair<std::uint32_t, std::uint32_t>> list_pairs(std::size_t* unmirrored) override {
    std::vector<std::uint32_t> j, len, host;  // (host sphere indices)
    to_host(j, rows_.j);
    to_host(len, rows_.length);
    to_host(host, s_host_);
    const std::size_t n = ns();
    std::vector<std::pair<std::uint32_t, std::uint32_t>> all, lo;
    for (std::size_t i = 0; i < n; ++i)
      for (std::uint32_t q = 0; q < len[i]; ++q) all.emplace_back(host[i], host[j[q * n + i]]);
    std::sort(all.begin(), all.end());
    std::size_t missing = 0;
    for (const auto& [a, c] : all) {
      if (!std::binary_search(all.begin(), all.end(), std::make_pair(c, a))) ++missing;
      if (a < c) lo.emplace_back(a, c);
    }
    if (unmirrored) *unmirrored = missing;
    return lo;
  }

  void upload() override;
  void download(bool history) override { download(history, false); }
  /// mid_step: after a drift, before the forces (a removal between the halves of a step): a pair
  /// the device marked touching at the last forces may since have moved apart by more than the
  /// skin, out of the host's new list; it is dropped (the next forces would release it: the
  /// same). At a full step such a pair is an internal error.
  void download(bool history, bool mid_step);
  void step() override { advance(1); }
  Advanced advance(std::uint64_t max_steps) override;
  void begin_settle(const SettleCriterion& c, std::uint64_t phase_step, std::uint64_t below) override;
  void end_settle() override;
  double kinetic_energy_j() override;
  double translational_kinetic_energy_j() override;
  void sync_walls() override;
  void retime_kernels() override {
    if (timed_choice() && !tuning_under_way()) restart_tuning();
  }
  void set_retime_every(std::uint64_t steps) override { retime_every_ = steps ? steps : 1; }

 private:
  BodyArrays body_arrays() {
    return {raw<Vec3>(b_pos_), raw<Vec3>(b_vel_), raw<Vec3>(b_omega_), raw<Vec3>(b_l_), raw<Vec3>(b_force_),
            raw<Vec3>(b_torque_), raw<Vec3>(b_inertia_), raw<Quat>(b_q_), raw<double>(b_mass_),
            raw<std::uint32_t>(b_first_), raw<std::uint32_t>(b_count_)};
  }
  SphereArrays sphere_arrays() {
    return {raw<Vec3>(s_pos_),    raw<Vec3>(s_vel_),    raw<Vec3>(s_omega_),       raw<Vec3>(s_offset_),
            raw<Vec3>(s_force_),  raw<Vec3>(s_torque_), raw<Vec3>(s_built_at_),    raw<double>(s_radius_),
            raw<double>(s_bmass_), raw<std::uint32_t>(s_body_), raw<std::uint32_t>(s_material_),
            raw<std::uint32_t>(s_sid_), raw<std::uint32_t>(s_contacts_),
            records_ ? raw<SphereRecord>(s_rec_) : nullptr};
  }
  struct Rows {
    vec<std::uint32_t> j, sid, mirror;
    vec<std::int32_t> image;
    vec<std::uint8_t> touching;
    vec<contact::ContactHistory> history;
    vec<std::uint32_t> length;
    std::uint32_t cap = 0;
    std::uint64_t generation = 0;  // changes whenever the buffers are reallocated (CUDA graphs hold their addresses)
    void resize(std::size_t n, std::uint32_t c, std::uint64_t gen) {
      cap = c;
      generation = gen;
      j.assign(n * c, 0u);
      sid.assign(n * c, 0u);
      mirror.assign(n * c, 0u);
      image.assign(n * c, 0);
      touching.assign(n * c, 0);
      history.assign(n * c, contact::ContactHistory{});
      length.assign(n, 0u);
    }
    RowArrays arrays() {
      return {raw<std::uint32_t>(j),      raw<std::uint32_t>(sid),    raw<std::int32_t>(image),
              raw<std::uint8_t>(touching), raw<contact::ContactHistory>(history), raw<std::uint32_t>(length),
              cap,                         raw<std::uint32_t>(mirror), nullptr,
              nullptr,                     nullptr,                    nullptr};
    }
  };

  /// The list build. `box`: the spheres' bounding box, from the list check's reduction (whose
  /// positions it found finite); null (upload): checked and reduced here.
  void build_list(const Box* box = nullptr);
  /// At a list build, after CellOf: sorts the bodies by the cell of their first sphere (stable)
  /// and reorders every body- and sphere-indexed array and the wall history to match; the rows
  /// are rebuilt right after, with their history carried over from the old rows (sphere_src_
  /// names each sphere's old row; entries match by stable id). False when the bodies were
  /// already in order (nothing moved).
  bool sort_bodies();
  /// The force kernels' arguments; `halt` as the step kernels (Halt{}: always evaluated).
  ContactArgs contact_args(const Halt& halt);
  /// Contact forces of every sphere; `halt` as the step kernels (Halt{}: always evaluated).
  void compute_forces(const Halt& halt);
  /// PairEntries alone (the sums then run in SumEntriesKickDrift).
  void launch_pair_entries(const ContactArgs& c);
  /// The two halves of a step around the list check: kick, drift and sphere update; then forces,
  /// body sums with the second half kick and, in a criterion phase, the settle update.
  void first_half();
  void second_half();
  /// The second half of step c and the first half of step c + 1 fused (outside criterion
  /// phases): forces, then ReduceKickDrift. With walk_kick(), one ForcesKickDrift that reads the
  /// sphere motion from one buffer and writes it to the other: `from_second` says which.
  void fused_unit(bool from_second);
  template <bool Cohesion, bool Rolling>
  void launch_walk_kicks(const ContactArgs& c, const ReduceKickDrift& rkd);
  template <bool Cohesion, bool Rolling>
  void launch_pair_entries_fixed(const ContactArgs& c, const FixedSumArrays& fx);
  /// SphereArrays with the sphere motion (centres, velocities, spins) of the second buffer.
  SphereArrays second_motion(SphereArrays a) {
    a.position = raw<Vec3>(s_pos2_);
    a.velocity = raw<Vec3>(s_vel2_);
    a.omega = raw<Vec3>(s_omega2_);
    if (records_) a.record = raw<SphereRecord>(s_rec2_);
    return a;
  }
  /// `units` times (second half of a step, first half of the next): the launches between two
  /// list checks, with no host wait (on CUDA: replayed as one CUDA graph when it can).
  void run_units(std::uint32_t units);
  /// Reads the device's settle state into settle_host_ (one small copy; waits for the device).
  void poll_settle();
  /// The step kernels' halt words: the settle state's flag in a criterion phase (none outside one,
  /// where it is never set: end_settle clears it), and the list guard's (StepFlags) unless
  /// BIODEM_GPU_LIST_GUARD=0.
  Halt halt() {
    return Halt{settle_active_ ? &raw<SettleState>(settle_)->settled : nullptr, guard_on_ ? raw<StepFlags>(guard_) : nullptr,
                0u};
  }
  /// The same for a kernel that drifts the spheres into motion buffer `buffer` (0: the first).
  Halt halt_writing(std::uint32_t buffer) {
    Halt h = halt();
    h.ignore = 1u << buffer;
    return h;
  }
  /// Sphere arrays a drift writes through, into motion buffer `buffer`: with the list guard's
  /// test (set_motion) unless the guard is off.
  SphereArrays drift_arrays(SphereArrays s, std::uint32_t buffer) {
    if (guard_on_) {
      s.guard = raw<StepFlags>(guard_);
      s.half_skin2 = 0.25 * skin_ * skin_;
      s.buffer = buffer;
    }
    return s;
  }
  // The list guard (StepFlags; docs/gpu.md "The list guard"): on unless BIODEM_GPU_LIST_GUARD=0;
  // its words on the device; the host's drift count when the device's was zeroed (upload); the
  // runs of steps launched since the last check that the guard may have stopped (their first
  // drift, units and whether they used the two motion buffers), and the guard's halts handled.
  bool guard_on_ = true;
  vec<StepFlags> guard_{1};
  std::uint64_t guard_base_ = 0;
  struct RunLaunched {
    std::uint64_t first_drift = 0;  // drifts_ before the run
    std::uint32_t units = 0;
    bool two_buffers = false;
  };
  std::vector<RunLaunched> runs_since_check_;
  std::uint64_t guard_halts_ = 0;
  /// After a drift that raised the guard's flag (Motion::guard_halted), in two parts (advance()
  /// sets the host clock back between them): guard_take_back reads how many drifts the device
  /// made (a wait), takes back the launched steps it did not make (the drift count, a kernel-set
  /// timing under way, which restarts), brings the motion into the first buffer if that drift
  /// wrote the second and clears the flags; returns the steps taken back. guard_rebuild checks
  /// the motion of now (a non-finite position stops the run, at the time of that drift) and
  /// builds the list at the positions of now, as the CPU engine's step does when a sphere has
  /// passed half the skin.
  std::uint64_t guard_take_back();
  void guard_rebuild();
  /// Steps to the next list check: as many as `room` (of half the skin) allows at `per_step` (the
  /// check's bound on a sphere's move per step), at least 1, at most check_every_ (also when
  /// nothing moves).
  std::uint32_t steps_to_next_check(double room, double per_step) const {
    return per_step > 0.0 ? static_cast<std::uint32_t>(
                                std::clamp(std::floor(room / per_step), 1.0, static_cast<double>(check_every_)))
                          : check_every_;
  }
  /// Whether the list guard's flags are raised now (reads them: a wait); false without the guard.
  bool guard_stopped_now();
  /// The host's walls to the device (upload, sync_walls).
  void copy_walls();
  /// Forgets the CUDA graphs (their kernels' arguments changed: buffers, walls, criterion).
  void invalidate_graphs() { graphs_.clear(); }
  void check_finite();
  std::uint32_t nb() const { return static_cast<std::uint32_t>(b_mass_.size()); }
  std::uint32_t ns() const { return static_cast<std::uint32_t>(s_radius_.size()); }
  auto exec() const { return System::exec(); }
  /// For the algorithms whose results stay on the device (sorts, scans, copies, gathers): on
  /// CUDA without a host wait after each (thrust::cuda::par_nosync), so that a list build waits
  /// for the device only where the host needs a value (the longest row).
  auto queue() const { return System::queue(); }
  /// Kernel launch over n indices (on the GPU without a host synchronisation: the next
  /// reduction synchronises).
  template <class F>
  void launch(std::uint32_t n, F f) {
    if (n) System::launch(n, f);
  }
  /// Row walks (Forces) over n items (System::launch_walks).
  template <class W>
  void launch_walks(std::uint32_t n, const W& w) {
    if (n) System::launch_walks(n, w, walk_single(), walk_pack(), pack_split());
  }
  /// The list check of every `check_every_` steps (docs/gpu.md): rebuild when a sphere could
  /// move more than half the skin before the next check. It reads the motion that the steps
  /// before it queued on the device one step before their end (no wait).
  /// Returns false when the motion it read shows that the list guard stopped the device (the
  /// caller then calls guard_take_back and guard_rebuild; nothing else was done).
  bool check_list();
  SphereMotion motion_of_sphere() {
    return SphereMotion{sphere_arrays(), raw<std::uint32_t>(mirror_missing_), guard_on_ ? raw<StepFlags>(guard_) : nullptr};
  }
  /// The list check's reduction over the current positions (waits for it).
  Motion motion_now();
  /// Stops the run with one line if the motion shows a pair missing from a row, a non-finite
  /// position or a sphere past half the skin; `lag`: steps the motion may be old. A sphere past
  /// half the skin is an error only where the list may have missed a contact: with a motion of
  /// earlier steps (lag > 0, positions the list gave forces at), or with the motion of now
  /// (lag 0: positions no forces were computed at yet) standing for the steps before it, once
  /// the list gave forces at positions other than those it was built at (forces_on_list_ > 1).
  /// A list used at its build positions alone missed nothing however far a sphere has moved
  /// since: the check rebuilds it before the forces (a sphere crossing more than half the skin
  /// in one step then has its list rebuilt at every step, as the CPU engine does).
  void check_motion(const Motion& m, std::uint32_t lag);
  // Force evaluations made with the current list, the one at its build positions included (the
  // host's at upload; the first step's after a rebuild at a check).
  std::uint64_t forces_on_list_ = 0;
  /// A lost body (SPEC 10; [run] lost_particles = "stop"; "remove" is apply_sinks' test): the CPU
  /// engine tests every body at each list build. Here the list check's box of the sphere centres
  /// says when one has left: a sphere beyond the lost region by more than the largest bounding
  /// radius belongs to a body whose centre is outside it (x and y past R + r_b of a drum, or a
  /// face of the box), so the host state is downloaded and the host's test names the body.
  /// (A body lost across a drum's diagonal is caught once it has moved one bounding radius
  /// further along an axis, or at the next sample.) Nothing is read back otherwise.
  void check_lost(const Motion& m);
  DeviceLostRegion device_lost_region() const;
  /// The case's [[sink]] regions (SPEC 10) and, with [run] lost_particles = "remove", its lost
  /// region, after the drift of every step whose number is a multiple of kSinkEvery (the
  /// host's step count, so a resumed run tests at the same steps): the bodies whose centre is
  /// inside a sink or may be lost are counted on the device (BodyInSink, BodyMayBeLost; a
  /// wait); if any, the state is downloaded, the host removes them (sim::Simulation::apply_sinks
  /// and check_lost_bodies, the CPU engine's rules, which count them) and uploads the rest: the
  /// list is built again and the next step checks. The CPU engine removes a body after the
  /// drift that took it into a sink, and a lost body at its next list build; here at most
  /// kSinkEvery - 1 steps later. Returns whether bodies were removed.
  /// Sinks::guard_stopped: the device had stopped at the list guard (found before the download
  /// that a removal makes; nothing done: the caller recovers and the test comes again).
  enum class Sinks { none, removed, guard_stopped };
  Sinks apply_sinks();
  static constexpr std::uint64_t kSinkEvery = 10;
  bool removes_lost() const {
    return host_.lost_region().kind != sim::LostRegion::Kind::None && host_.lost_region().remove;
  }
  /// Steps from the one whose first half is done to the next that tests the sinks (0: this one);
  /// no limit without sinks or lost bodies to remove.
  std::uint64_t steps_to_sink_test() const {
    if (host_.sinks().empty() && !removes_lost()) return ~std::uint64_t{0};
    return (kSinkEvery - host_.step_count() % kSinkEvery) % kSinkEvery;
  }
  vec<sim::SinkSpec> sinks_;
  std::uint64_t sink_tests_ = 0, sink_removals_ = 0;  // removal tests made, and those that removed bodies
  std::uint64_t graph_runs_ = 0, plain_runs_ = 0;     // runs of steps launched as a CUDA graph, and plainly
  // The list check's motion, queued by run_units before the last step of each run of steps
  // (inside the CUDA graph) and read by the next check: whether one is queued and unread, the
  // drifts made so far and when it was queued (the check reads a motion drifts_ - motion_drifts_
  // steps old, normally 1).
  typename System::template Pending<Motion> motion_;
  bool motion_queued_ = false;
  bool queued_checks_ = true;  // BIODEM_GPU_QUEUED_CHECK; off for the rest of a run if reading one fails
  // In a criterion phase, the settle state queued likewise (before the last step of a run of
  // steps) and read at the next check instead of a waiting copy; whether one is queued.
  typename System::template PendingCopy<SettleState> settle_copy_{"a settle poll"};
  bool settle_queued_ = false;
  std::uint64_t drifts_ = 0, motion_drifts_ = 0;
  std::uint64_t waitless_checks_ = 0;  // checks that read a queued motion

  sim::Simulation& host_;
  std::string name_;
  // bodies
  vec<Vec3> b_pos_, b_vel_, b_omega_, b_l_, b_force_, b_torque_, b_inertia_;
  vec<Quat> b_q_;
  vec<double> b_mass_;
  vec<std::uint32_t> b_first_, b_count_;
  // spheres
  vec<Vec3> s_pos_, s_vel_, s_omega_, s_offset_, s_force_, s_torque_, s_built_at_;
  vec<double> s_radius_, s_bmass_;
  vec<std::uint32_t> s_body_, s_material_, s_sid_, s_contacts_;
  std::vector<std::uint32_t> sid_host_;  // stable sphere id of each host sphere (host order)
  // The device's storage order against the host Simulation's (docs/gpu.md, "Bodies sorted by
  // cell"): host body of each device body slot, device slot of each host body, host sphere of
  // each device sphere. The identity after upload(), until the first sort.
  vec<std::uint32_t> b_host_, b_slot_, s_host_;
  // A sort's work arrays: body keys, the new order of the bodies, the old first spheres and each
  // new sphere's old index; scratch of each element type.
  vec<std::uint32_t> body_key_, body_order_, sphere_src_;
  // The stashes of a Permutation: one per array reordered at once (enlarged only).
  struct Stash {
    vec<Vec3> v3[Permutation::kMost];
    vec<Quat> q[Permutation::kMost];
    vec<double> d[Permutation::kMost];
    vec<std::uint32_t> u[Permutation::kMost];
  } body_stash_, sphere_stash_;
  /// Adds the live array `a` to permutation p, with the next stash of its type (enlarged to fit).
  template <class T>
  void add_to(Permutation& p, Stash& st, vec<T>& a) {
    auto take = [&](int& count, vec<T>* stashes, T** live, T** stash) {
      if (count == Permutation::kMost) throw InternalError("internal: more arrays of one type than a Permutation holds");
      vec<T>& s = stashes[count];
      if (s.size() < a.size()) s.resize(a.size());
      live[count] = raw<T>(a);
      stash[count] = raw<T>(s);
      ++count;
    };
    if constexpr (std::is_same_v<T, Vec3>) {
      take(p.n3, st.v3, p.v3, p.v3_stash);
    } else if constexpr (std::is_same_v<T, Quat>) {
      take(p.nq, st.q, p.q, p.q_stash);
    } else if constexpr (std::is_same_v<T, double>) {
      take(p.nd, st.d, p.d, p.d_stash);
    } else {
      static_assert(std::is_same_v<T, std::uint32_t>);
      take(p.nu, st.u, p.u, p.u_stash);
    }
  }

  vec<contact::ContactHistory> tmp_history_;
  vec<std::uint8_t> tmp_u8_;
  std::uint32_t sort_every_ = kSortEvery;  // 0: never
  bool grouped_build_ = launch_switches().build_lanes_log2 != 0;  // BuildRowsGrouped (BIODEM_GPU_BUILD_LANES)
  std::uint64_t grouped_builds_ = 0;        // row builds by BuildRowsGrouped
  std::uint32_t builds_until_sort_ = 0;    // the build that sorts when this reaches 0 (0: none due)
  std::uint64_t sorts_ = 0;                // sorts that reordered the bodies
  // neighbour list: current and previous rows (history carried from one to the other)
  Rows rows_, old_rows_;
  vec<std::uint32_t> cell_key_, sorted_, cell_start_;
  vec<Int3> wrap_, cell_;
  // the spheres' data in cell order, for BuildRows (PackByCell)
  vec<Vec3> packed_pos_;
  vec<double> packed_radius_;
  vec<std::uint32_t> packed_body_, packed_sid_;
  vec<Int3> packed_wrap_;
  // walls and pair table
  vec<DeviceWall> walls_;
  // Translating walls (MoveWalls): their schedules, how many, and the device clock they follow.
  vec<DeviceWallMotion> wall_motion_;
  vec<double> wall_clock_;
  std::uint32_t n_moving_walls_ = 0;
  /// Moves the translating walls to the next step's time (before its contact kernels); nothing
  /// without them.
  void move_walls() {
    if (n_moving_walls_)
      launch(1, MoveWalls{raw<DeviceWall>(walls_), raw<DeviceWallMotion>(wall_motion_), n_moving_walls_,
                          raw<double>(wall_clock_), dt_, halt()});
  }
  vec<contact::ContactHistory> wall_history_;
  vec<std::uint8_t> wall_touching_;
  vec<contact::PairParams> pairs_;
  std::uint32_t n_walls_ = 0, n_materials_ = 0;
  bool cohesion_ = false, rolling_ = false;
  neighbor::Domain domain_;
  double skin_ = 0.0, dt_ = 0.0, r_max_ = 0.0;
  double skin_diameters_ = 0.0;  // BIODEM_GPU_SKIN_DIAMETERS (0: the case's skin)
  std::uint64_t fault_at_step_ = 0;  // BIODEM_TEST_GPU_FAULT_AT_STEP (0: none)
  bool fault_in_thrust_ = false;     // BIODEM_TEST_GPU_FAULT_IN_THRUST
  Vec3 gravity_;
  std::uint64_t builds_ = 0;
  std::uint64_t widenings_ = 0;  // list builds redone with wider rows
  std::uint32_t check_every_ = 10, steps_until_check_ = 1;
  std::uint64_t generation_ = 0;  // source of Rows::generation
  // Settle criterion evaluated on the device (begin_settle ... end_settle).
  vec<SettleState> settle_{1};
  vec<double> ke_sum_;  // the kinetic energy of the last step, then System's scratch
  bool settle_active_ = false;
  SettleCriterion criterion_;
  SettleState settle_host_;  // as last read from the device
  typename System::Graphs graphs_;
  bool fuse_ = true;                // ReduceKickDrift between list checks outside criterion phases
  enum class ForcesMode { automatic, entries, rows, timed };
  ForcesMode forces_mode_ = ForcesMode::automatic;
  /// The choice of the contact kernels by timing (BIODEM_GPU_FORCES=timed, and auto on a GPU;
  /// the rules in timed_choice.hpp): after each upload the runs of steps between list checks
  /// go through the candidate sets of the scene (candidate_sets), each run timed on the device
  /// (System::Timer); a set more than 1.25 times as slow as the fastest in the first round is
  /// dropped, the others are timed in three more rounds, and the one with the lowest median time
  /// per step runs on. All give the same bits, so the choice changes no result. (On CPU threads
  /// the walks with the row lanes and in one thread are the same code, and packed walks run as
  /// a group of one lane.) The sets are timed again at the start of each phase (retime_kernels)
  /// and after every kRetimeSteps steps of the chosen set (set_retime_every): the first timing
  /// after an upload sees the bed as inserted (few contacts), where the sets' order can differ
  /// from that of a bed at rest (H100, glass_small: the row walk in one thread and the entry
  /// kernels within 1 % over the first 160 steps, 25 and 18 us/step at rest).
  static constexpr std::uint64_t kRetimeSteps = 20000;
  std::uint64_t retime_every_ = kRetimeSteps;
  TimedChoice tuning_;
  std::size_t scene_spheres_ = 0;  // the spheres of the scene uploaded last (candidate_sets)
  std::uint32_t choices_ = 0;       // choices made in the run so far
  std::uint64_t since_choice_ = 0;  // steps run with the set chosen
  /// The sets the timed choice tries in this scene, in the order it tries them (first the
  /// per-contact kernels, then the row walks), each switch forced by its environment variable
  /// leaving only its own value:
  /// - per-contact, with the sums in one thread per sphere and by the row lanes (SUM_LANES);
  /// - the row walk by the row lanes (in single-sphere scenes with the body update: ForcesKickDrift);
  /// - the row walk in one thread per sphere, apart from the body update and with it (WALK_KICK;
  ///   single spheres: ForcesKickDrift, clumps of up to 32 spheres: ForcesKickDriftGroups), each
  ///   with and without the warp's touching contacts shared (WALK_PACK), the shared ones but
  ///   ForcesKickDriftGroups also by 2 lanes per sphere, and by 4 where that fits in one wave of
  ///   the device (PACK_SPLIT); in scenes of clumps the walks apart also with the body kernel by
  ///   lanes (BODY_LANES).
  /// The order-free family: per-contact, the row lanes, one thread (it has no other).
  std::vector<KernelSet> candidate_sets() const {
    std::vector<KernelSet> v;
    for (const bool sl : {false, true}) {
      if (sl && fixed_sums_) continue;
      if (sum_lanes_mode_ != SumLanes::automatic && sl != (sum_lanes_mode_ == SumLanes::on)) continue;
      v.push_back(KernelSet{.entries = true, .sum_lanes = sl});
    }
    // Each set says what runs, forced switches included (so that run.log names it).
    const bool kick_fits = !fixed_sums_ && walk_kick_fits();
    std::vector<bool> kicks{kick_fits && walk_kick_mode_ == WalkKick::on};
    if (kick_fits && walk_kick_mode_ == WalkKick::automatic) kicks = {false, true};
    std::vector<bool> packs{!fixed_sums_ && walk_pack_mode_ == WalkPack::on};
    if (!fixed_sums_ && walk_pack_mode_ == WalkPack::automatic) packs = {false, true};
    // (the body kernel by lanes: clumps, the walk apart from the body update; forced, every such set)
    const std::uint32_t bl_log2 = body_lanes_forced_ ? body_lanes_log2_ : body_lanes_auto_log2_;
    std::vector<bool> bls{body_lanes_forced_ && bl_log2 > 0};
    if (!body_lanes_forced_ && bl_log2 > 0) bls = {false, true};
    // the row lanes (in single-sphere scenes with the body update unless it is switched off; in
    // scenes of clumps with the body update forced, that is ForcesKickDriftGroups again: left out)
    if (single_spheres_ || fixed_sums_ || kicks.front() == false)
      v.push_back(KernelSet{.kick = single_spheres_ && kick_fits && walk_kick_mode_ != WalkKick::off});
    for (const bool kick : kicks)
      for (const bool pack : packs) {
        const bool clumps_apart = !single_spheres_ && !kick && !fixed_sums_;
        for (const bool bl : clumps_apart ? bls : std::vector<bool>{false})
          v.push_back(KernelSet{.single = true, .kick = kick, .pack = pack, .body_lanes = bl});
        // (the packed walks also by 2 lanes per sphere, and by 4 where that many threads fit in
        // one wave of the device (PACK_SPLIT unset; forced, every packed set is split), but
        // ForcesKickDriftGroups, which has its own groups)
        if (pack && (single_spheres_ || !kick) && !pack_split_forced_)
          for (std::uint8_t sp = 1; sp <= 2; ++sp)
            if (sp == 1 || (static_cast<std::uint64_t>(scene_spheres_) << sp) <= System::wave_threads())
              v.push_back(KernelSet{.single = true, .kick = kick, .pack = true, .split = sp});
      }
    return v;
  }
  /// The sets are timed from the next run of steps on; with `size_buffers`, the entry kernels'
  /// buffers are made to fit the rows now (a list build enlarges them only while they are in
  /// use or timed; upload's own build does it for the new scene).
  void restart_tuning(bool size_buffers = true) {
    tuning_.start(candidate_sets());
    since_choice_ = 0;
    if (size_buffers && timed_choice() && rows_.length.size() == ns()) ensure_entry_buffers();
  }
  typename System::Timer timer_;
  bool timed_choice() const {
    return forces_mode_ == ForcesMode::timed || (forces_mode_ == ForcesMode::automatic && System::kTimedChoice);
  }
  bool tuning_under_way() const { return timed_choice() && tuning_.under_way(); }
  /// The set of the timed choice that runs now (under way: the one being timed).
  const KernelSet& tuned_set() const { return tuning_.current_set(); }
  /// PairEntries + SumEntries instead of Forces.
  bool use_entry_kernels() const {
    switch (forces_mode_) {
      case ForcesMode::entries: return true;
      case ForcesMode::rows: return false;
      default: break;
    }
    if (!timed_choice()) return ns() < kEntryForcesBelow;
    return tuned_set().entries;
  }
  /// The row walk in one thread per sphere instead of the row lanes (the timed choice only).
  bool walk_single() const { return timed_choice() && !use_entry_kernels() && tuned_set().single; }
  /// The row walk fused with the body update (single-sphere scenes: ForcesKickDrift; clumps of up
  /// to 32 spheres: ForcesKickDriftGroups; BIODEM_GPU_WALK_KICK; the timed choice's sets with
  /// `kick`: in single-sphere scenes the walk with the row lanes too), in the fused units of a
  /// row walk.
  enum class WalkKick { automatic, off, on };
  WalkKick walk_kick_mode_ = WalkKick::automatic;
  bool walk_kick() const {
    if (entries_ready() || fixed_sums_) return false;  // (the order-free family has none)
    if (!walk_kick_fits()) return false;
    if (walk_kick_mode_ != WalkKick::automatic) return walk_kick_mode_ == WalkKick::on;
    return timed_choice() && tuned_set().kick;
  }
  std::uint64_t walk_kick_units_ = 0;
  // In scenes of clumps, ForcesKickDriftGroups' lanes per body (log2; upload: the most spheres
  // of a body rounded up to a power of two; above 5, more than 32: no such set).
  std::uint32_t walk_kick_lanes_log2_ = 0;
  /// The scene has a kernel for the walk with the body update (not for a body of more than 32 spheres).
  bool walk_kick_fits() const { return single_spheres_ || walk_kick_lanes_log2_ <= 5; }
  vec<Vec3> s_pos2_, s_vel2_, s_omega2_;  // the sphere motion's second buffer (ForcesKickDrift)
  // The spheres' records (BIODEM_GPU_RECORDS=1; SphereRecord), and those of the second buffer.
  bool records_ = false, own_sphere_ = false;
  // The fused body kernel's lanes per body in scenes of clumps (BIODEM_GPU_BODY_LANES; log2; 0:
  // one thread per body); auto: set at upload from the most spheres of a body. Unset: the timed
  // choice's sets with `body_lanes` use the lanes of auto, the rest (and every other choice) one
  // thread per body.
  std::uint32_t body_lanes_log2_ = 0, body_lanes_auto_log2_ = 0;
  bool body_lanes_auto_ = false, body_lanes_forced_ = false;
  /// The lanes per body (log2) of the fused body kernel now (0: ReduceKickDrift in one thread).
  std::uint32_t body_lanes() const {
    if (single_spheres_) return 0;
    if (body_lanes_forced_) return body_lanes_log2_;
    return timed_choice() && !use_entry_kernels() && tuned_set().body_lanes ? body_lanes_auto_log2_ : 0;
  }
  /// The warp's row walks in one thread sharing their touching contacts (BIODEM_GPU_WALK_PACK=1,
  /// or the timed choice's sets with `pack`).
  enum class WalkPack { automatic, off, on };
  WalkPack walk_pack_mode_ = WalkPack::automatic;
  bool walk_pack() const {
    if (walk_pack_mode_ != WalkPack::automatic) return walk_pack_mode_ == WalkPack::on;
    return timed_choice() && !use_entry_kernels() && tuned_set().pack;
  }
  /// The lanes per sphere (log2) of the packed walks (BIODEM_GPU_PACK_SPLIT, or the timed
  /// choice's sets with `split`; on CPU threads one lane whatever this says).
  std::uint32_t pack_split_log2_ = 0;
  bool pack_split_forced_ = false;
  std::uint32_t pack_split() const {
    if (!walk_pack() || (walk_kick() && !single_spheres_)) return 0;  // (ForcesKickDriftGroups: its own groups)
    if (pack_split_forced_) return pack_split_log2_;
    return timed_choice() && !use_entry_kernels() ? tuned_set().split : 0u;
  }
  vec<SphereRecord> s_rec_, s_rec2_;
  /// The records filled from the arrays (upload, after a sort): both buffers' (the second's
  /// motion is written before it is read; its radii, masses and materials are these).
  void pack_records() {
    if (!records_ || !ns()) return;
    launch(ns(), PackRecords{sphere_arrays(), raw<SphereRecord>(s_rec_)});
    if (s_rec2_.size() == ns()) launch(ns(), PackRecords{sphere_arrays(), raw<SphereRecord>(s_rec2_)});
  }
  /// The entry kernels' per-sphere sums by the row lanes (BIODEM_GPU_SUM_LANES; the timed
  /// choice's sets with `sum_lanes`).
  enum class SumLanes { automatic, off, on };
  SumLanes sum_lanes_mode_ = SumLanes::automatic;
  bool sum_lanes() const {
    if (sum_lanes_mode_ != SumLanes::automatic) return sum_lanes_mode_ == SumLanes::on;
    return timed_choice() && use_entry_kernels() && tuned_set().sum_lanes;
  }
  std::uint64_t entry_passes_ = 0;  // steps whose forces the entry kernels evaluated
  /// The pair list of the per-contact passes (ContactArgs::PairList; BIODEM_GPU_PAIR_LIST):
  /// the lower-id entries in index order, rebuilt at each list build; its capacity grows only
  /// (the CUDA graphs hold its address), with an eighth to spare.
  bool compact_pairs_ = true;
  std::uint64_t row_entries_ = 0;          // entries of all rows at the last build (each pair twice)
  std::uint64_t near_wall_slots_ = 0;      // wall slots within reach at the last build
  vec<std::uint32_t> pair_k_, pair_j_, pair_offset_;  // the listed entries, their neighbours (same capacity)
  vec<std::uint32_t> pair_count_ = vec<std::uint32_t>(1, 0u);
  std::uint32_t pair_cap_ = 0;
  vec<std::uint32_t> wall_k_, wall_offset_;
  vec<std::uint32_t> wall_count_ = vec<std::uint32_t>(1, 0u);
  std::uint32_t wall_cap_ = 0;
  /// WallSlotNear with the spheres at `positions`: at a build their positions now (which the
  /// build then keeps as s_built_at_), at a wall update between builds s_built_at_ (so that the
  /// spheres' moves until the next build, less than half the skin from there, stay within it).
  WallSlotNear wall_slot_near(const Vec3* positions) {
    return WallSlotNear{positions, raw<double>(s_radius_), raw<DeviceWall>(walls_), raw<std::uint8_t>(wall_touching_),
                        ns(), skin_};
  }
  const Vec3* wall_list_positions_ = nullptr;  // (build_wall_list's: set by its callers)
  /// A list of the indices 0 .. total - 1 that `flag` marks, in index order (flag, exclusive
  /// scan, ScatterFlagged; no host wait), `expected` of them (the build's reduction), into
  /// `list` of capacity `cap` (grown to expected plus an eighth when short, never shrunk: the
  /// graphs then forgotten) with its count in `count`; `what` names the entries in the 32-bit
  /// error. With `also`, also[place] = also_from[index] for each listed index (`also` kept at
  /// the list's capacity: resized with it, or when its size differs).
  template <class Flag>
  void build_flag_list(const Flag& flag, std::uint32_t total, std::uint64_t expected, vec<std::uint32_t>& list,
                       vec<std::uint32_t>& offset, vec<std::uint32_t>& count, std::uint32_t& cap, const char* what,
                       vec<std::uint32_t>* also = nullptr, const std::uint32_t* also_from = nullptr) {
    if (expected > cap || list.empty() || (also && also->size() != list.size())) {
      const std::uint64_t c = std::max<std::uint64_t>(expected + expected / 8 + 32, cap);
      if (c > 0xffffffffull) throw Error("GPU engine: " + std::to_string(expected) + " " + what + " exceed 2^32 (32-bit indices)");
      cap = static_cast<std::uint32_t>(c);
      list.resize(cap);
      if (also) also->resize(cap);
      invalidate_graphs();
    }
    if (total == 0) {
      thrust::fill(queue(), count.begin(), count.end(), 0u);
      return;
    }
    offset.resize(total);
    thrust::transform_exclusive_scan(queue(), thrust::counting_iterator<std::uint32_t>(0),
                                     thrust::counting_iterator<std::uint32_t>(total), offset.begin(), flag, 0u,
                                     thrust::plus<std::uint32_t>());
    launch(total, ScatterFlagged<Flag>{flag, raw<std::uint32_t>(offset), total, cap, raw<std::uint32_t>(list),
                                       raw<std::uint32_t>(count), raw<std::uint32_t>(mirror_missing_), also_from,
                                       also ? raw<std::uint32_t>(*also) : nullptr});
  }
  /// The wall-slot list (the slots within reach, WallSlotNear) of near_wall_slots_ slots, at
  /// wall_list_positions_.
  void build_wall_list() {
    build_flag_list(wall_slot_near(wall_list_positions_), n_walls_ * ns(), near_wall_slots_, wall_k_, wall_offset_,
                    wall_count_, wall_cap_, "wall slots");
  }
  /// The pair list (the lower-id entries, LowerSide): half the rows' entries.
  void build_pair_list() {
    build_flag_list(LowerSide{rows_.arrays(), raw<std::uint32_t>(s_sid_), ns()}, rows_.cap * ns(), row_entries_ / 2,
                    pair_k_, pair_offset_, pair_count_, pair_cap_, "pairs", &pair_j_, rows_.arrays().j);
  }
  std::uint32_t pair_pass_threads() const {
    ContactArgs::PairList l;
    l.on = compact_pairs_;
    l.cap = pair_cap_;
    l.wall_cap = wall_cap_;
    return ContactArgs::pass_threads(l, rows_.cap, n_walls_, ns());
  }
  /// The order-free family (BIODEM_GPU_SUMS=fixed): the per-sphere sums as fixed-point integers
  /// (FixedSumArrays), their grid chosen at upload (fixed_grid) unless a test set it.
  bool fixed_sums_ = false;
  bool fixed_caps_set_ = false;
  double fixed_force_scale_ = 1.0, fixed_torque_scale_ = 1.0;
  vec<long long> fixed_sums_buf_;      // FixedSumArrays::kWords * ns(), zero between steps
  std::uint64_t fixed_passes_ = 0;     // steps whose sums were fixed-point
  void ensure_fixed_sums() {
    if (fixed_sums_buf_.size() == FixedSumArrays::kWords * static_cast<std::size_t>(ns())) return;
    fixed_sums_buf_.assign(FixedSumArrays::kWords * static_cast<std::size_t>(ns()), 0);
    invalidate_graphs();
  }
  FixedSumArrays fixed_arrays() {
    return {raw<long long>(fixed_sums_buf_), fixed_force_scale_, 1.0 / fixed_force_scale_, fixed_torque_scale_,
            1.0 / fixed_torque_scale_, fixed::limit_for(rows_.cap + n_walls_)};
  }
  /// The grid of the fixed-point sums from the case: contributions up to the Hertz and SJKR
  /// forces of the stiffest and most cohesive pair at an overlap of the largest radius (far
  /// beyond any overlap a stable run reaches), four times over for damping, and torques up to
  /// that force times the largest diameter, fit in 2^56 quanta (fixed::scale_for).
  void fixed_grid();
  /// For the non-finite stop's message: a refused fixed-point contribution ends there too.
  std::string fixed_range_hint() const {
    if (!fixed_sums_) return "";
    char b[160];
    std::snprintf(b, sizeof b, " or, with BIODEM_GPU_SUMS=fixed, a contact force or torque beyond its range of %.3g N and %.3g N m",
                  fixed::limit_for(rows_.cap + n_walls_) / fixed_force_scale_,
                  fixed::limit_for(rows_.cap + n_walls_) / fixed_torque_scale_);
    return b;
  }
  vec<Vec3> entry_force_, entry_torque_;  // rows_.cap * ns() entries, enlarged at list builds
  vec<Vec3> wall_force_, wall_torque_;    // n_walls_ * ns() wall slots, likewise
  vec<std::uint32_t> mirror_missing_ = vec<std::uint32_t>(1, 0u);  // set by MirrorEntries if a pair's other entry is missing (read at downloads)
  [[noreturn]] static void throw_unmirrored() {
    throw InternalError("internal: the GPU engine's neighbour list holds a pair in one of its two rows only (or its pair or "
                "wall-slot list outgrew its capacity)");
  }
  /// Both entries of every touching pair hold its history again (MirrorHistory), after steps of
  /// PairEntries, which advance it in the lower-id side's entry only.
  void mirror_history() {
    launch(rows_.cap * ns(), MirrorHistory{rows_.arrays(), raw<std::uint32_t>(s_sid_), ns()});
  }
  /// The entry kernels' buffers fit rows of `cap` and the walls.
  /// Enlarges the entry kernels' buffers (only) to fit rows of rows_.cap and the walls.
  void ensure_entry_buffers();
  bool entries_ready_for(std::uint32_t cap) const {
    return entry_force_.size() >= static_cast<std::size_t>(cap) * ns() &&
           wall_force_.size() >= static_cast<std::size_t>(n_walls_) * ns();
  }
  /// The entry kernels are on and their buffers fit the rows and walls (else Forces runs).
  bool entries_ready() const { return use_entry_kernels() && entries_ready_for(rows_.cap); }
  template <bool Cohesion, bool Rolling>
  void launch_forces(const ContactArgs& c);
  std::uint64_t fused_units_ = 0;   // (second half, first half) pairs done by the fused kernel
  bool single_spheres_ = false;     // every body has one sphere (upload)
  bool centred_spheres_ = false;    // and that sphere at its centre: the body kernels skip the offset's load
  std::uint64_t summed_in_kick_ = 0;  // fused units whose sphere sums ran in SumEntriesKickDrift
  /// BIODEM_GPU_PROFILE=1: the host waits for the device after each run of units, list check and
  /// build, and adds up their wall times (a wait the step loop makes anyway at every check, so
  /// the figures are those of a plain run to within a wait per check).
  struct Profile {
    bool on = false;
    double advance_s = 0.0, units_s = 0.0, checks_s = 0.0, builds_s = 0.0;
    std::uint64_t steps = 0, units = 0, checks = 0, builds = 0;
  } profile_;
  using Clock = std::chrono::steady_clock;
  static double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }
  typename System::Staging staging_;  // download()'s copies

 public:
  void set_check_every(std::uint32_t k) override {
    check_every_ = std::max<std::uint32_t>(1, k);
    steps_until_check_ = 1;
  }
};

inline void Engine::copy_walls() {
  invalidate_graphs();
  // The host's translating walls where their schedules have them now (the host does not move
  // them while the device steps), then the device's copies, their schedules and clock.
  host_.update_wall_motion(host_.time_s());
  const auto& w = host_.walls();
  std::vector<DeviceWall> dw(w.size());
  std::vector<DeviceWallMotion> motion;
  for (std::size_t k = 0; k < w.size(); ++k) {
    dw[k] = {w[k].geometry, w[k].material, w[k].translates() ? 1u : 0u};
    if (w[k].translates()) motion.push_back({host_.translation_of_wall(k), static_cast<std::uint32_t>(k)});
  }
  to_device(walls_, dw);
  n_moving_walls_ = static_cast<std::uint32_t>(motion.size());
  to_device(wall_motion_, motion);
  to_device(wall_clock_, std::vector<double>{host_.time_s()});
}

inline void Engine::sync_walls() {
  copy_walls();
  // The wall-slot list after a change of the walls between builds (a phase start), from the
  // spheres' positions at the last build: they move less than half the skin from there before
  // the next build.
  if (compact_pairs_ && ns() && rows_.length.size() == ns() && s_built_at_.size() == ns() &&
      wall_touching_.size() == n_walls_ * static_cast<std::size_t>(ns()) && walls_.size() == n_walls_) {
    near_wall_slots_ = thrust::transform_reduce(
                           exec(), thrust::counting_iterator<std::uint32_t>(0), thrust::counting_iterator<std::uint32_t>(ns()),
                           SphereListStats{raw<std::uint32_t>(rows_.length), wall_slot_near(raw<Vec3>(s_built_at_)), n_walls_},
                           RowLengths{}, RowLengthsMax{})
                           .wall_slots;
    wall_list_positions_ = raw<Vec3>(s_built_at_);
    build_wall_list();
  }
}

inline void Engine::upload() {
  // An upload replaces the device's list with one built at the positions of now (an insertion
  // wave, a removal): a sphere already past half the skin at positions the old list gave forces
  // at, where contacts may have been missed since the last check, stops the run here as that
  // check would have, instead of being hidden by the new list.
  if (ns() && builds_) check_motion(motion_now(), 0);
  invalidate_graphs();
  const auto& pt = host_.pair_table();
  if (host_.walls().size() > kMaxDeviceWalls)
    throw Error("--device gpu: the scene has " + std::to_string(host_.walls().size()) +
                " walls; the GPU engine tests every wall for every sphere and takes at most " +
                std::to_string(kMaxDeviceWalls));
  const auto& b = host_.bodies();
  const auto& s = host_.spheres();
  dt_ = host_.dt_s();
  gravity_ = host_.gravity_m_s2();
  domain_ = host_.domain();
  skin_ = host_.skin_m();
  double rmin = 1e300;
  for (double r : s.radius_m) rmin = std::min(rmin, r);
  if (skin_ < 0.0) {  // not yet resolved by a host refresh: the same default (neighbor/skin.hpp)
    skin_ = s.size() ? neighbor::default_skin_m(rmin) : 1e-3;
  }
  if (skin_diameters_ > 0.0 && s.size()) skin_ = skin_diameters_ * 2.0 * rmin;
  r_max_ = 0.0;
  for (double r : s.radius_m) r_max_ = std::max(r_max_, r);
  cohesion_ = pt.any_cohesion();
  rolling_ = pt.any_rolling();
  n_materials_ = static_cast<std::uint32_t>(pt.materials());
  std::vector<contact::PairParams> table(n_materials_ * n_materials_);
  for (std::uint32_t a = 0; a < n_materials_; ++a)
    for (std::uint32_t c = 0; c < n_materials_; ++c) table[a * n_materials_ + c] = pt(a, c);
  to_device(pairs_, table);
  if (fixed_sums_ && !fixed_caps_set_) fixed_grid();
  copy_walls();  // (the wall-slot list follows with the list build below)
  n_walls_ = static_cast<std::uint32_t>(host_.walls().size());

  to_device(b_pos_, b.position_m);
  to_device(b_vel_, b.velocity_m_s);
  to_device(b_omega_, b.angular_velocity_rad_s);
  to_device(b_l_, b.angular_momentum_kg_m2_s);
  to_device(b_force_, b.force_n);
  to_device(b_torque_, b.torque_n_m);
  to_device(b_inertia_, b.inertia_kg_m2);
  to_device(b_q_, b.orientation);
  to_device(b_mass_, b.mass_kg);
  to_device(b_first_, b.first_sphere);
  to_device(b_count_, b.sphere_count);
  mirror_missing_[0] = 0u;
  motion_queued_ = false;  // (of the state before the upload)
  settle_queued_ = false;
  // (SumEntriesKickDrift takes body k's sphere to be sphere k)
  single_spheres_ = true;
  for (std::size_t k = 0; k < b.size(); ++k)
    if (b.sphere_count[k] != 1 || b.first_sphere[k] != k) single_spheres_ = false;
  // (a body sort keeps both: a one-sphere body's sphere moves with it, its offset with it)
  centred_spheres_ = single_spheres_ && std::all_of(s.offset_body_m.begin(), s.offset_body_m.end(),
                                                    [](const Vec3& o) { return o == Vec3{}; });
  {
    std::uint32_t most = 1;
    for (std::uint32_t c : b.sphere_count) most = std::max(most, c);
    walk_kick_lanes_log2_ = 0;
    while (walk_kick_lanes_log2_ < 6 && (1u << walk_kick_lanes_log2_) < most) ++walk_kick_lanes_log2_;
    body_lanes_auto_log2_ = std::min<std::uint32_t>(walk_kick_lanes_log2_, 5u);
    if (body_lanes_auto_) body_lanes_log2_ = body_lanes_auto_log2_;
  }
  scene_spheres_ = s.size();
  // (the candidate sets depend on the scene above; the list build below sizes the entry
  // buffers for the new scene)
  restart_tuning(false);

  const std::size_t n = s.size();
  // Stable sphere ids: spheres numbered body by body in stable body id order.
  {
    std::vector<std::uint32_t> order(b.size());
    std::iota(order.begin(), order.end(), 0u);
    std::sort(order.begin(), order.end(), [&](std::uint32_t x, std::uint32_t y) { return b.id[x] < b.id[y]; });
    sid_host_.assign(n, 0);
    std::uint32_t next = 0;
    for (std::uint32_t k : order)
      for (std::uint32_t q = 0; q < b.sphere_count[k]; ++q) sid_host_[b.first_sphere[k] + q] = next++;
  }
  std::vector<std::uint32_t> body(s.body.begin(), s.body.end()), material(s.material.begin(), s.material.end());
  to_device(s_pos_, s.position_m);
  to_device(s_vel_, s.velocity_m_s);
  to_device(s_omega_, s.angular_velocity_rad_s);
  if (walk_kick_fits()) {  // (ForcesKickDrift's second buffer: written before it is read)
    s_pos2_.resize(n);
    s_vel2_.resize(n);
    s_omega2_.resize(n);
  }
  to_device(s_offset_, s.offset_body_m);
  to_device(s_force_, s.force_n);
  to_device(s_torque_, s.torque_n_m);
  to_device(s_radius_, s.radius_m);
  to_device(s_bmass_, s.body_mass_kg);
  to_device(s_body_, body);
  to_device(s_material_, material);
  to_device(s_sid_, sid_host_);
  s_contacts_.assign(n, 0u);
  if (fixed_sums_) fixed_sums_buf_.assign(FixedSumArrays::kWords * n, 0);
  // The host's order; the list build below sorts the bodies (when sorting is on).
  b_host_.resize(b.size());
  b_slot_.resize(b.size());
  s_host_.resize(n);
  thrust::sequence(exec(), b_host_.begin(), b_host_.end());
  thrust::sequence(exec(), b_slot_.begin(), b_slot_.end());
  thrust::sequence(exec(), s_host_.begin(), s_host_.end());
  builds_until_sort_ = sort_every_ ? 1 : 0;
  s_built_at_.assign(n, Vec3{});

  // Contact history of touching pairs from the host list (entries (i, j), history from i's side),
  // as "old rows" holding each pair in both spheres' rows, from the lower stable id's side.
  const auto& L = host_.neighbor_list();
  std::vector<std::vector<std::pair<std::uint32_t, contact::ContactHistory>>> per(n);
  if (L.row_start.size() >= 2) {
    const std::size_t rows_known = std::min(n, L.row_start.size() - 1);
    for (std::size_t i = 0; i < rows_known; ++i)
      for (std::uint32_t k = L.row_start[i]; k < L.row_start[i + 1]; ++k) {
        if (!L.touching[k] || L.j[k] >= n) continue;
        const std::uint32_t j = L.j[k];
        contact::ContactHistory h = L.history[k];
        if (sid_host_[i] > sid_host_[j]) {
          h.xi = -h.xi;
          h.m_r = -h.m_r;
        }
        per[i].emplace_back(j, h);
        per[j].emplace_back(static_cast<std::uint32_t>(i), h);
      }
  }
  std::size_t cap = 1;
  for (auto& r : per) {
    std::sort(r.begin(), r.end(), [&](const auto& x, const auto& y) { return sid_host_[x.first] < sid_host_[y.first]; });
    cap = std::max(cap, r.size());
  }
  {
    std::vector<std::uint32_t> j(n * cap, 0), sid(n * cap, 0), len(n, 0);
    std::vector<std::uint8_t> touch(n * cap, 0);
    std::vector<contact::ContactHistory> hist(n * cap);
    for (std::size_t i = 0; i < n; ++i) {
      len[i] = static_cast<std::uint32_t>(per[i].size());
      for (std::size_t q = 0; q < per[i].size(); ++q) {
        j[q * n + i] = per[i][q].first;
        sid[q * n + i] = sid_host_[per[i][q].first];
        hist[q * n + i] = per[i][q].second;
        touch[q * n + i] = 1;
      }
    }
    // Held as the current rows: build_list() makes them the old rows it carries history from.
    rows_.cap = static_cast<std::uint32_t>(cap);
    rows_.generation = ++generation_;
    to_device(rows_.j, j);
    to_device(rows_.sid, sid);
    to_device(rows_.length, len);
    to_device(rows_.touching, touch);
    to_device(rows_.history, hist);
    rows_.image.assign(n * cap, 0);
    rows_.mirror.assign(n * cap, 0u);
  }

  // Wall history: host sparse table (per sphere: candidate walls) -> device [wall * n + sphere].
  {
    const auto& wc = host_.wall_contacts();
    std::vector<contact::ContactHistory> h(n * n_walls_);
    std::vector<std::uint8_t> t(n * n_walls_, 0);
    if (wc.start.size() == n + 1)
      for (std::size_t i = 0; i < n; ++i)
        for (std::uint32_t k = wc.start[i]; k < wc.start[i + 1]; ++k)
          if (wc.touching[k] && wc.wall[k] < n_walls_) {
            h[wc.wall[k] * n + i] = wc.history[k];
            t[wc.wall[k] * n + i] = 1;
          }
    to_device(wall_history_, h);
    to_device(wall_touching_, t);
  }

  if (records_) {
    s_rec_.resize(n);
    s_rec2_.resize(walk_kick_fits() ? n : 0);
    pack_records();  // (radii, masses, materials; SpheresFromBodies writes the motion)
  }
  launch(ns(), SpheresFromBodies{body_arrays(), sphere_arrays()});
  guard_[0] = StepFlags{};  // (the device's drift count from 0 at the host's count of now)
  guard_base_ = drifts_;
  runs_since_check_.clear();
  build_list();
  forces_on_list_ = 1;     // (the host's forces, at the build positions)
  steps_until_check_ = 1;  // the first step checks
  // The queued list check's and settle poll's buffers (pinned memory, an event); if they cannot
  // be had, the checks and polls wait for the device instead, for the rest of the run.
  if (queued_checks_) {
    try {
      if (ns() && motion_.prepare(ns(), motion_of_sphere(), MotionMax{}, Motion{})) invalidate_graphs();
      if (settle_copy_.prepare()) invalidate_graphs();
    } catch (const DeviceFault&) {
      throw;
    } catch (const Error& e) {
      queued_checks_ = false;
      invalidate_graphs();
      std::fprintf(stderr, "biodem: %s; the list checks wait for their reduction for the rest of the run\n", e.what());
    }
  }
  if (!host_.forces_current()) {
    // Set-up or after an insertion: forces for the first half kick, without advancing the
    // contact history (this is not a time step), as the CPU engine's refresh().
    const auto hist = rows_.history;
    const auto touch = rows_.touching;
    const auto whist = wall_history_;
    const auto wtouch = wall_touching_;
    compute_forces(Halt{});
    // Keep the history of pairs that were touching before; new contacts start from zero. On the
    // device, without a round trip through the host.
    launch(static_cast<std::uint32_t>(rows_.history.size()),
           KeepSetupHistory{raw<contact::ContactHistory>(rows_.history), thrust::raw_pointer_cast(hist.data()),
                            raw<std::uint8_t>(rows_.touching), thrust::raw_pointer_cast(touch.data())});
    launch(static_cast<std::uint32_t>(wall_history_.size()),
           KeepSetupHistory{raw<contact::ContactHistory>(wall_history_), thrust::raw_pointer_cast(whist.data()),
                            raw<std::uint8_t>(wall_touching_), thrust::raw_pointer_cast(wtouch.data())});
    launch(nb(), ReduceKick{body_arrays(), sphere_arrays(), gravity_, 0.5 * dt_, false, Halt{}});
  }
  ke_sum_.assign(System::sum_scratch(nb()), 0.0);
  if (settle_active_) {  // (not expected: the run driver uploads outside criterion phases)
    settle_[0] = settle_host_;
  }
}

inline void Engine::check_finite() {
  const std::uint32_t n = ns();
  const std::uint32_t first = thrust::transform_reduce(exec(), thrust::counting_iterator<std::uint32_t>(0),
                                                       thrust::counting_iterator<std::uint32_t>(n),
                                                       FirstNotFinite{sphere_arrays(), n}, n, thrust::minimum<std::uint32_t>());
  if (first != n) {
    std::vector<std::uint32_t> body, b_host, s_host;  // named by the host's indices
    to_host(body, s_body_);
    to_host(b_host, b_host_);
    to_host(s_host, s_host_);
    throw Error("sphere " + std::to_string(s_host[first]) + " (of body " + std::to_string(b_host[body[first]]) +
                ") has a non-finite position at t = " + std::to_string(host_.time_s()) +
                " s: the simulation became unstable (is [run].dt_s too large?" + fixed_range_hint() + ")");
  }
}

inline void Engine::build_list(const Box* known_box) {
  // The list guard's flags concern the list being replaced: a drift past half the skin of it
  // (the last, which no forces followed) is within the new list's reach.
  if (guard_on_) launch(1, ClearGuardOver{raw<StepFlags>(guard_)});
  const std::uint32_t n = ns();
  if (n == 0) {  // (no rows: the pair and wall lists of a scene uploaded before must not be read)
    thrust::fill(queue(), pair_count_.begin(), pair_count_.end(), 0u);
    thrust::fill(queue(), wall_count_.begin(), wall_count_.end(), 0u);
    return;
  }
  Box box;
  if (known_box) {
    box = *known_box;
  } else {
    check_finite();
    box = thrust::transform_reduce(exec(), thrust::counting_iterator<std::uint32_t>(0),
                                   thrust::counting_iterator<std::uint32_t>(n), BoxOfSphere{sphere_arrays()}, Box{},
                                   BoxUnion{});
  }
  const double cutoff = 2.0 * r_max_ + skin_;
  GridParams g;
  const Vec3 len = domain_.length_m();
  double cell = cutoff;
  // Cells along a periodic axis: a whole number of at least the cut-off, as many as the cells of
  // the other axes' size fit, but never fewer than 3 while the period holds 3 cut-offs (so that a
  // sparse bed, or a sphere far away on another axis, coarsening the cells does not make the
  // period too short for the list).
  auto periodic_cells = [&](int k, double c) {
    const double fine = std::floor(len[k] / cutoff), coarse = std::floor(len[k] / c);
    return std::max(std::min(3.0, fine), coarse);
  };
  bool sized = false;
  // At most ~4 cells per sphere (sparse scenes), as the CPU list; up to 4096 enlargements, enough
  // for any finite extent (a sphere far away cannot make the 32-bit cell keys overflow).
  for (int iter = 0; iter < 4096 && !sized; ++iter) {
    double cells = 1.0;
    for (int k = 0; k < 3; ++k)
      cells *= std::max(1.0, domain_.periodic[k] ? periodic_cells(k, cell) : std::floor((box.hi[k] - box.lo[k]) / cell));
    sized = cells <= 4.0 * static_cast<double>(n) + 27.0;
    if (!sized) cell *= 1.26;
  }
  if (!sized)  // (not expected: positions are finite here)
    throw Error("GPU engine: the spheres span " + std::to_string(box.hi.x - box.lo.x) + " x " +
                std::to_string(box.hi.y - box.lo.y) + " x " + std::to_string(box.hi.z - box.lo.z) +
                " m at t = " + std::to_string(host_.time_s()) +
                " s, too wide for the neighbour grid (has a sphere flown far away?)");
  g.cell = cell;
  int nn[3];
  for (int k = 0; k < 3; ++k) {
    g.periodic[k] = domain_.periodic[k];
    if (domain_.periodic[k]) {
      g.lo[k] = domain_.lo_m[k];
      g.period[k] = len[k];
      // Image shifts are stored in 8 bits (pack_image) and positions are never wrapped: as the CPU
      // list, stop once a sphere has gone round a periodic axis more than 60 times (the box of
      // the spheres says so without a pass of its own) rather than give wrong pairs.
      const double w = std::max(std::abs(std::floor((box.lo[k] - g.lo[k]) / len[k])),
                                std::abs(std::floor((box.hi[k] - g.lo[k]) / len[k])));
      if (!(w <= 60.0))
        throw Error("a sphere is " + std::to_string(w) + " periodic lengths away along axis " + std::to_string(k) +
                    " (at most 60 are supported)");
      nn[k] = static_cast<int>(periodic_cells(k, cell));
      if (nn[k] < 3)
        throw Error("periodic length along axis " + std::to_string(k) +
                    " is shorter than 3 neighbour cells (largest sphere diameter + skin)");
    } else {
      g.lo[k] = box.lo[k];
      nn[k] = std::max(1, static_cast<int>(std::floor((box.hi[k] - box.lo[k]) / cell)) + 1);
    }
  }
  g.n = Int3{nn[0], nn[1], nn[2]};
  const std::size_t ncell = static_cast<std::size_t>(nn[0]) * nn[1] * nn[2];

  cell_key_.resize(n);
  wrap_.resize(n);
  cell_.resize(n);
  sorted_.resize(n);
  launch(n, CellOf{sphere_arrays(), g, raw<std::uint32_t>(cell_key_), raw<Int3>(wrap_), raw<Int3>(cell_)});
  const std::uint32_t* old_of = nullptr;  // set when this build reorders the bodies (BuildRows)
  if (builds_until_sort_ && --builds_until_sort_ == 0) {
    builds_until_sort_ = sort_every_;
    if (sort_bodies()) {
      launch(n, CellOf{sphere_arrays(), g, raw<std::uint32_t>(cell_key_), raw<Int3>(wrap_), raw<Int3>(cell_)});
      old_of = raw<std::uint32_t>(sphere_src_);
    }
  }
  thrust::sequence(queue(), sorted_.begin(), sorted_.end());
  thrust::stable_sort_by_key(queue(), cell_key_.begin(), cell_key_.end(), sorted_.begin());  // keys not needed after
  cell_start_.resize(ncell + 1);
  thrust::lower_bound(queue(), cell_key_.begin(), cell_key_.end(), thrust::counting_iterator<std::uint32_t>(0),
                      thrust::counting_iterator<std::uint32_t>(static_cast<std::uint32_t>(ncell + 1)),
                      cell_start_.begin());
  packed_pos_.resize(n);
  packed_radius_.resize(n);
  packed_body_.resize(n);
  packed_sid_.resize(n);
  packed_wrap_.resize(n);
  const CellPacked packed{raw<Vec3>(packed_pos_), raw<double>(packed_radius_), raw<std::uint32_t>(packed_body_),
                          raw<std::uint32_t>(packed_sid_), raw<Int3>(packed_wrap_)};
  launch(n, PackByCell{sphere_arrays(), raw<std::uint32_t>(sorted_), raw<Int3>(wrap_), packed});

  // The current rows become the old rows; build new ones, enlarging them until every row fits.
  // The capacity starts at the wider of the two sets: after a widening the set swapped in is the
  // one of two builds ago, and starting at its capacity would overflow (and widen) again.
  std::swap(rows_, old_rows_);
  std::uint32_t cap = std::max({rows_.cap, old_rows_.cap, std::uint32_t{16}});
  bool grouped = false;  // the rows kept were built by BuildRowsGrouped
  for (;;) {
    // The kernels over entries and wall slots index them by a 32-bit (q * n + sphere): checked
    // before rows of this capacity are made and built.
    if ((static_cast<std::uint64_t>(cap) + n_walls_) * n > 0xffffffffull)
      throw Error("GPU engine: " + std::to_string(n) + " spheres with neighbour rows of " + std::to_string(cap) +
                  " entries and " + std::to_string(n_walls_) + " walls exceed 2^32 entries (32-bit indices)");
    if (rows_.cap != cap || rows_.length.size() != n) rows_.resize(n, cap, ++generation_);
    const RowBuildArgs args{sphere_arrays(), g, raw<std::uint32_t>(sorted_), raw<std::uint32_t>(cell_start_), packed,
                            raw<Int3>(wrap_), raw<Int3>(cell_), old_rows_.arrays(), rows_.arrays(), n, skin_, old_of};
    grouped = grouped_build_ && cap <= kGroupRowCap;
    if (grouped) {
      System::launch_row_builds(n, BuildRowsGrouped{args});
    } else {
      launch(n, BuildRows{args});
    }
    const RowLengths lengths = thrust::transform_reduce(
        exec(), thrust::counting_iterator<std::uint32_t>(0), thrust::counting_iterator<std::uint32_t>(n),
        SphereListStats{raw<std::uint32_t>(rows_.length), wall_slot_near(raw<Vec3>(s_pos_)), n_walls_}, RowLengths{},
        RowLengthsMax{});
    const std::uint32_t longest = lengths.longest;
    row_entries_ = lengths.total;
    near_wall_slots_ = lengths.wall_slots;
    if (longest <= cap) break;
    cap = longest + longest / 4 + 1;
    ++widenings_;
  }
  grouped_builds_ += grouped;
  // Each pair's other entry, for PairEntries (which evaluates a pair once, from its lower-id side).
  launch(rows_.cap * n, MirrorEntries{rows_.arrays(), raw<std::uint32_t>(s_sid_), n, raw<std::uint32_t>(mirror_missing_)});
  if (compact_pairs_) {
    build_pair_list();
    wall_list_positions_ = raw<Vec3>(s_pos_);
    build_wall_list();
  }
  if (static_cast<std::uint64_t>(pair_cap_) + wall_cap_ > 0xffffffffull)
    throw Error("GPU engine: " + std::to_string(pair_cap_) + " pairs and " + std::to_string(wall_cap_) +
                " wall slots exceed 2^32 threads (32-bit indices)");
  thrust::copy(queue(), s_pos_.begin(), s_pos_.end(), s_built_at_.begin());
  // The entry kernels' buffers: enlarged only (the CUDA graphs hold their addresses).
  if (use_entry_kernels() || tuning_under_way()) ensure_entry_buffers();
  ++builds_;
}

inline void Engine::ensure_entry_buffers() {
  if (entries_ready_for(rows_.cap)) return;
  const std::uint32_t n = ns();
  entry_force_.resize(std::max(entry_force_.size(), static_cast<std::size_t>(rows_.cap) * n));
  entry_torque_.resize(entry_force_.size());
  wall_force_.resize(std::max(wall_force_.size(), static_cast<std::size_t>(n_walls_) * n));
  wall_torque_.resize(wall_force_.size());
  invalidate_graphs();
}


inline bool Engine::sort_bodies() {
  const std::uint32_t m = nb(), n = ns();
  // Key of a body: the cell of its first sphere (CellOf has just run), in the list's cell order.
  body_key_.resize(m);
  thrust::gather(queue(), b_first_.begin(), b_first_.end(), cell_key_.begin(), body_key_.begin());
  if (m < 2 || thrust::transform_reduce(exec(), thrust::counting_iterator<std::uint32_t>(0),
                                        thrust::counting_iterator<std::uint32_t>(m - 1),
                                        Descends{raw<std::uint32_t>(body_key_)}, 0u, thrust::plus<std::uint32_t>()) == 0)
    return false;
  body_order_.resize(m);
  thrust::sequence(queue(), body_order_.begin(), body_order_.end());
  thrust::stable_sort_by_key(queue(), body_key_.begin(), body_key_.end(), body_order_.begin());
  // Bodies: every array stashed, then gathered in the new order (the first spheres are stashed
  // only: the old ones name each body's spheres for SphereSources, the new ones are the
  // exclusive scan of the new counts).
  Permutation pb;
  for (auto* a : {&b_pos_, &b_vel_, &b_omega_, &b_l_, &b_force_, &b_torque_, &b_inertia_}) add_to(pb, body_stash_, *a);
  add_to(pb, body_stash_, b_q_);
  add_to(pb, body_stash_, b_mass_);
  add_to(pb, body_stash_, b_count_);
  add_to(pb, body_stash_, b_host_);
  const int first_slot = pb.nu;  // b_first_, added last: stashed, not gathered
  add_to(pb, body_stash_, b_first_);
  launch(m, pb);  // stash
  pb.nu = first_slot;
  pb.src = raw<std::uint32_t>(body_order_);
  launch(m, pb);  // gather
  const std::uint32_t* old_first = pb.u_stash[first_slot];
  thrust::exclusive_scan(queue(), b_count_.begin(), b_count_.end(), b_first_.begin());
  thrust::scatter(queue(), thrust::counting_iterator<std::uint32_t>(0), thrust::counting_iterator<std::uint32_t>(m),
                  b_host_.begin(), b_slot_.begin());
  sphere_src_.resize(n);
  launch(m, SphereSources{raw<std::uint32_t>(body_order_), old_first, raw<std::uint32_t>(b_first_),
                          raw<std::uint32_t>(b_count_), raw<std::uint32_t>(sphere_src_), raw<std::uint32_t>(s_body_)});
  // Spheres (s_built_at_ is overwritten by this build; cell_key_, wrap_, cell_ are recomputed).
  Permutation ps;
  for (auto* a : {&s_pos_, &s_vel_, &s_omega_, &s_offset_, &s_force_, &s_torque_}) add_to(ps, sphere_stash_, *a);
  add_to(ps, sphere_stash_, s_radius_);
  add_to(ps, sphere_stash_, s_bmass_);
  for (auto* a : {&s_material_, &s_sid_, &s_contacts_, &s_host_}) add_to(ps, sphere_stash_, *a);
  launch(n, ps);  // stash
  ps.src = raw<std::uint32_t>(sphere_src_);
  launch(n, ps);  // gather
  pack_records();
  // Wall history [wall * n + sphere].
  if (n_walls_) {
    const auto slots = thrust::make_transform_iterator(thrust::counting_iterator<std::uint32_t>(0),
                                                       WallSlotSource{raw<std::uint32_t>(sphere_src_), n});
    const std::size_t count = static_cast<std::size_t>(n_walls_) * n;
    if (tmp_history_.size() < count) tmp_history_.resize(count);
    if (tmp_u8_.size() < count) tmp_u8_.resize(count);
    thrust::copy(queue(), wall_history_.begin(), wall_history_.end(), tmp_history_.begin());
    thrust::copy(queue(), wall_touching_.begin(), wall_touching_.end(), tmp_u8_.begin());
    thrust::gather(queue(), slots, slots + count, tmp_history_.begin(), wall_history_.begin());
    thrust::gather(queue(), slots, slots + count, tmp_u8_.begin(), wall_touching_.begin());
  }
  ++sorts_;
  return true;
}

inline ContactArgs Engine::contact_args(const Halt& halt) {
  ContactArgs c;
  c.s = sphere_arrays();
  c.rows = rows_.arrays();
  if (compact_pairs_) {
    c.pair_list.k = raw<std::uint32_t>(pair_k_);
    c.pair_list.j = raw<std::uint32_t>(pair_j_);
    c.pair_list.count = raw<std::uint32_t>(pair_count_);
    c.pair_list.cap = pair_cap_;
    c.pair_list.on = true;
    c.pair_list.wall_k = raw<std::uint32_t>(wall_k_);
    c.pair_list.wall_count = raw<std::uint32_t>(wall_count_);
    c.pair_list.wall_cap = wall_cap_;
  }
  c.rows.entry_force = raw<Vec3>(entry_force_);
  c.rows.entry_torque = raw<Vec3>(entry_torque_);
  c.rows.wall_force = raw<Vec3>(wall_force_);
  c.rows.wall_torque = raw<Vec3>(wall_torque_);
  c.walls = raw<DeviceWall>(walls_);
  c.wall_history = raw<contact::ContactHistory>(wall_history_);
  c.wall_touching = raw<std::uint8_t>(wall_touching_);
  c.n_walls = n_walls_;
  c.pairs = raw<contact::PairParams>(pairs_);
  c.n_materials = n_materials_;
  c.period = domain_.length_m();
  c.periodic = domain_.any_periodic();
  c.n = ns();
  c.dt = dt_;
  c.wall_rolling_lab = host_.wall_rolling_lab();
  c.halt = halt;
  c.own_sphere = own_sphere_;
  return c;
}

inline void Engine::compute_forces(const Halt& halt) {
  const ContactArgs c = contact_args(halt);
  if (cohesion_) {
    if (rolling_) launch_forces<true, true>(c);
    else launch_forces<true, false>(c);
  } else {
    if (rolling_) launch_forces<false, true>(c);
    else launch_forces<false, false>(c);
  }
}

template <bool Cohesion, bool Rolling>
void Engine::launch_forces(const ContactArgs& c) {
  if (fixed_sums_ && entries_ready()) {
    PairEntriesFixed<Cohesion, Rolling> pe;
    static_cast<ContactArgs&>(pe) = c;
    pe.fx = fixed_arrays();
    launch(pair_pass_threads(), pe);
    launch(ns(), TakeFixedSums{pe.fx, c.s, c.halt});
    return;
  }
  if (fixed_sums_) {  // the order-free family's row walk, its sums as integers (row lanes or one thread)
    ForcesFixed<Cohesion, Rolling> w;
    static_cast<ContactArgs&>(w) = c;
    w.fx = fixed_arrays();
    launch_walks(ns(), w);
    return;
  }
  if (entries_ready()) {
    launch(pair_pass_threads(), PairEntries<Cohesion, Rolling>{c});
    if (sum_lanes()) {
      if (ns()) System::launch_walks(ns(), SumEntriesWalk{c}, false);
    } else {
      launch(ns(), SumEntries<Cohesion, Rolling>{c});
    }
  } else {
    launch_walks(ns(), Forces<Cohesion, Rolling>{c});
  }
}

inline void Engine::first_half() {
  launch(nb(), KickDriftSpheres{body_arrays(), drift_arrays(sphere_arrays(), 0), 0.5 * dt_, dt_, halt_writing(0),
                                centred_spheres_});
}

inline void Engine::second_half() {
  move_walls();
  compute_forces(halt());
  launch(nb(), ReduceKick{body_arrays(), sphere_arrays(), gravity_, 0.5 * dt_, true, halt()});
  if (!settle_active_) return;
  double* ke = raw<double>(ke_sum_);
  const std::uint32_t* slot = raw<std::uint32_t>(b_slot_);  // the sum in the host's body order
  if (criterion_.translational)
    System::sum_into(nb(), InHostOrder<BodyTranslationalKineticEnergy>{{body_arrays()}, slot}, ke, halt());
  else
    System::sum_into(nb(), InHostOrder<BodyKineticEnergy>{{body_arrays()}, slot}, ke, halt());
  launch(1, SettleUpdate{raw<SettleState>(settle_), ke, static_cast<double>(nb()), criterion_.threshold_j,
                         criterion_.min_steps, criterion_.hold_steps, halt()});
}

inline void Engine::fused_unit(bool from_second) {
  move_walls();
  // (the drift writes the first motion buffer, except ForcesKickDrift's from the first below)
  const ReduceKickDrift rkd{body_arrays(), drift_arrays(sphere_arrays(), 0), gravity_, 0.5 * dt_, dt_, halt_writing(0),
                            centred_spheres_};
  if (fixed_sums_ && entries_ready()) {  // the order-free family: the sums inside the body kernel
    const ContactArgs c = contact_args(halt());
    const FixedSumArrays fx = fixed_arrays();
    if (cohesion_) {
      if (rolling_) launch_pair_entries_fixed<true, true>(c, fx);
      else launch_pair_entries_fixed<true, false>(c, fx);
    } else {
      if (rolling_) launch_pair_entries_fixed<false, true>(c, fx);
      else launch_pair_entries_fixed<false, false>(c, fx);
    }
    launch(nb(), ReduceKickDriftFixed{rkd, fx, single_spheres_});
    return;
  }
  if (walk_kick()) {  // row walk: the body update inside the walk, two buffers
    // One kernel reads the motion from one buffer and drifts into the other: it never reads the
    // list guard's flag of the buffer it writes (Halt::ignore).
    const std::uint32_t written = from_second ? 0u : 1u;
    ContactArgs c = contact_args(halt_writing(written));
    ReduceKickDrift out = rkd;
    out.halt = halt_writing(written);
    if (from_second) c.s = second_motion(c.s);
    else out.s = drift_arrays(second_motion(sphere_arrays()), 1);
    if (cohesion_) {
      if (rolling_) launch_walk_kicks<true, true>(c, out);
      else launch_walk_kicks<true, false>(c, out);
    } else {
      if (rolling_) launch_walk_kicks<false, true>(c, out);
      else launch_walk_kicks<false, false>(c, out);
    }
    return;
  }
  if (single_spheres_ && entries_ready()) {  // glass beads: the sums inside ReduceKickDrift
    const ContactArgs c = contact_args(halt());
    launch_pair_entries(c);
    if (!sum_lanes()) launch(nb(), SumEntriesKickDrift{c, rkd});
    else if (nb()) System::launch_walks(nb(), SumEntriesKickDriftWalk{c, rkd}, false);
    return;
  }
  compute_forces(halt());
  if (const std::uint32_t lanes_log2 = body_lanes()) {
    if (nb()) System::launch_groups(nb(), ReduceKickDriftLanes{rkd}, lanes_log2);
  } else {
    launch(nb(), rkd);
  }
}

template <bool Cohesion, bool Rolling>
void Engine::launch_pair_entries_fixed(const ContactArgs& c, const FixedSumArrays& fx) {
  PairEntriesFixed<Cohesion, Rolling> pe;
  static_cast<ContactArgs&>(pe) = c;
  pe.fx = fx;
  launch(pair_pass_threads(), pe);
}

inline void Engine::fixed_grid() {
  const auto& pt = host_.pair_table();
  double y = 0.0, kc = 0.0, r = 0.0;
  for (std::size_t a = 0; a < pt.materials(); ++a)
    for (std::size_t c = 0; c < pt.materials(); ++c)
      if (pt(a, c).defined) {
        y = std::max(y, pt(a, c).y_eff_pa);
        kc = std::max(kc, pt(a, c).cohesion_energy_density_j_m3);
      }
  for (double ri : host_.spheres().radius_m) r = std::max(r, ri);
  r = std::max(r_max_, r);
  const double r2 = r * r;
  const double force_cap = 4.0 * (4.0 / 3.0 * y * r2 + kc * 3.141592653589793 * r2);
  fixed_force_scale_ = fixed::scale_for(force_cap);
  fixed_torque_scale_ = fixed::scale_for(2.0 * r * force_cap);
}

template <bool Cohesion, bool Rolling>
void Engine::launch_walk_kicks(const ContactArgs& c, const ReduceKickDrift& rkd) {
  if (!single_spheres_) {  // clumps: a group of lanes per body (ForcesKickDriftGroups)
    ForcesKickDriftGroups<Cohesion, Rolling> g;
    static_cast<ContactArgs&>(g.walk) = c;
    g.out = ReduceKickDriftLanes{rkd};
    if (nb() && walk_pack()) System::launch_groups_packed(nb(), g, walk_kick_lanes_log2_);
    else if (nb()) System::launch_groups(nb(), g, walk_kick_lanes_log2_);
    return;
  }
  ForcesKickDrift<Cohesion, Rolling> w;
  static_cast<ContactArgs&>(w) = c;
  w.rkd = rkd;
  launch_walks(nb(), w);
}

inline void Engine::launch_pair_entries(const ContactArgs& c) {
  const std::uint32_t n = pair_pass_threads();
  if (cohesion_) {
    if (rolling_) launch(n, PairEntries<true, true>{c});
    else launch(n, PairEntries<true, false>{c});
  } else {
    if (rolling_) launch(n, PairEntries<false, true>{c});
    else launch(n, PairEntries<false, false>{c});
  }
}

inline void Engine::run_units(std::uint32_t units) {
  // Outside a criterion phase nothing runs between ReduceKick of step c and KickDriftSpheres of
  // step c + 1: one fused kernel (ReduceKickDrift) does both, with the same bits.
  const bool fused = fuse_ && !settle_active_;
  // ForcesKickDrift's units alternate the two buffers of the sphere motion (unit u reads the
  // second when u is odd); after an odd number of units the motion is copied back to the first,
  // which holds it between runs.
  const bool two_buffers = fused && walk_kick();
  auto record = [this, units, fused, two_buffers] {
    for (std::uint32_t u = 0; u < units; ++u) {
      const bool from_second = two_buffers && u % 2 == 1;
      const bool queue_for_check = u + 1 == units && ns() && queued_checks_;  // (read at the next check)
      if (queue_for_check) {
        SphereMotion m = motion_of_sphere();
        if (from_second) m.s = second_motion(m.s);
        motion_.enqueue(ns(), m, MotionMax{}, Motion{});
      }
      if (fused) {
        fused_unit(from_second);
      } else {
        second_half();
        // The settle state after the last step's update (a criterion phase never fuses; the
        // first half that follows does not touch it), so the check sees the last step too.
        if (queue_for_check && settle_active_) settle_copy_.enqueue(raw<SettleState>(settle_));
        first_half();
      }
    }
    if (two_buffers && units % 2 == 1) {
      // (not after a drift the list guard stopped at an earlier unit: guard_take_back copies
      // the buffer that drift wrote; after the last unit's, its flag moves to the first buffer)
      Halt h = halt();
      h.ignore = 3u;
      launch(ns(), CopySphereMotion{raw<Vec3>(s_pos2_), raw<Vec3>(s_vel2_), raw<Vec3>(s_omega2_), raw<Vec3>(s_pos_),
                                    raw<Vec3>(s_vel_), raw<Vec3>(s_omega_),
                                    records_ ? raw<SphereRecord>(s_rec2_) : nullptr,
                                    records_ ? raw<SphereRecord>(s_rec_) : nullptr, h});
    }
  };
  const bool entries = entries_ready();
  if (ns()) runs_since_check_.push_back(RunLaunched{drifts_, units, two_buffers});
  if (fused) fused_units_ += units;
  if (two_buffers) walk_kick_units_ += units;
  if (fused && single_spheres_ && entries && !fixed_sums_) summed_in_kick_ += units;
  if (entries) entry_passes_ += units;
  if (fixed_sums_) fixed_passes_ += units;
  // The kernels' arguments are the same every step: a graph is valid until a buffer is
  // reallocated (rows: by generation; the others: invalidate_graphs) or the criterion changes.
  // Longer runs between checks (set_check_every above 64) are launched plainly.
  const std::uint64_t key = graph_key(GraphKeyParts{.generation = rows_.generation,
                                                    .units = units,
                                                    .translational = criterion_.translational,
                                                    .settle = settle_active_,
                                                    .fused = fused,
                                                    .sum_lanes = sum_lanes(),
                                                    .walk_single = walk_single(),
                                                    .entries = entries,
                                                    .queued_checks = queued_checks_,
                                                    .two_buffers = two_buffers,
                                                    .fixed_sums = fixed_sums_,
                                                    .walk_pack = walk_pack(),
                                                    .body_lanes_log2 = body_lanes(),
                                                    .pack_split_log2 = pack_split()});
  const bool timing = tuning_under_way();
  // A trial times the steps only: a graph captured for them is captured before the timer starts.
  if (timing && units <= kMostUnitsInAGraph) graphs_.prepare(key, record);
  if (timing) timer_.start();
  const auto t0 = Clock::now();
  if (units > kMostUnitsInAGraph || !graphs_.run(key, record)) {
    record();
    ++plain_runs_;
  } else {
    ++graph_runs_;
  }
  if (profile_.on) {
    System::wait();
    profile_.units_s += since(t0);
    profile_.units += units;
  }
  forces_on_list_ += units;
  motion_queued_ = ns() != 0 && queued_checks_;
  settle_queued_ = motion_queued_ && settle_active_;
  motion_drifts_ = drifts_ + units - 1;
  drifts_ += units;
  if (timing) {
    tuning_.record(timer_.stop() / units, units);
    if (!tuning_.under_way()) ++choices_;
    // The row walk reads both entries of a pair: after entry steps, hand it the history.
    if (entries && !entries_ready()) mirror_history();
  } else if (timed_choice()) {
    since_choice_ += units;
    if (since_choice_ >= retime_every_) restart_tuning();
  }
}

inline void Engine::poll_settle() {
  std::vector<SettleState> st;
  to_host(st, settle_);
  settle_host_ = st[0];
  settle_queued_ = false;  // (older than this)
}

inline void Engine::begin_settle(const SettleCriterion& c, std::uint64_t phase_step, std::uint64_t below) {
  invalidate_graphs();
  if (ke_sum_.size() < System::sum_scratch(nb())) ke_sum_.assign(System::sum_scratch(nb()), 0.0);
  criterion_ = c;
  settle_active_ = true;
  settle_queued_ = false;
  settle_host_ = SettleState{phase_step, below, 0u};
  settle_[0] = settle_host_;
}

inline void Engine::end_settle() {
  invalidate_graphs();
  settle_active_ = false;
  settle_queued_ = false;
  criterion_ = SettleCriterion{};
  settle_host_ = SettleState{};
  settle_[0] = settle_host_;  // the step kernels run again
}

inline DeviceEngine::Advanced Engine::advance(std::uint64_t max_steps) {
  Advanced r;
  if (settle_active_ && settle_host_.settled) {
    r.below = settle_host_.below;
    r.settled = true;
    return r;
  }
  if (max_steps == 0) {
    r.below = settle_host_.below;
    return r;
  }
  if (fault_at_step_ && host_.step_count() >= fault_at_step_) {  // (test hook, above)
    fault_at_step_ = 0;
    System::inject_fault();
    if (fault_in_thrust_) check_finite();  // (a Thrust reduction that waits for the device)
  }
  const std::uint64_t step0 = host_.step_count(), k0 = settle_host_.k;
  const double t0 = host_.time_s();
  const auto clock0 = Clock::now();
  auto tick = [this](std::uint64_t n) {  // the host clock follows the launches (for messages)
    for (std::uint64_t q = 0; q < n; ++q) {
      host_.set_time_s(host_.time_s() + dt_);
      host_.set_step_count(host_.step_count() + 1);
    }
  };
  // Steps cur = 1 .. max_steps: first half, the list check when due, second half. Between two
  // checks the launches are (second half of step c, first half of step c + 1) units.
  std::uint64_t cur = 1;
  bool stopped = false;
  first_half();
  ++drifts_;
  tick(1);
  // The list guard stopped the device after a drift past half the skin (check_list, apply_sinks,
  // or the read after the last forces): the steps launched after it are taken back (the host
  // clock too), the list is built at the positions of that drift, and the steps go on from there.
  bool checked = false;  // (guard_rebuild made the check of the step of now)
  auto recover = [&] {
    const std::uint64_t back = guard_take_back();
    if (back >= cur) throw InternalError("internal: GPU engine: the list guard took back more steps than advance made");
    cur -= back;
    host_.set_step_count(step0);
    host_.set_time_s(t0);
    tick(cur);
    guard_rebuild();
  };
  for (;;) {
    if (checked) {
      checked = false;
    } else if (--steps_until_check_ == 0) {
      if (settle_active_) {
        // The state queued at the last step's update (no wait: the device is still on that
        // step's first half), else a waiting copy.
        bool read = false;
        if (settle_queued_) {
          try {
            settle_host_ = settle_copy_.get();
            read = true;
          } catch (const DeviceFault&) {  // a kernel faulted: nothing can go on (no fallback line)
            throw;
          } catch (const Error& e) {
            queued_checks_ = false;
            invalidate_graphs();
            std::fprintf(stderr, "biodem: %s; the list checks wait for their reduction for the rest of the run\n",
                         e.what());
          }
        }
        if (!read) poll_settle();
        settle_queued_ = false;
        if (settle_host_.settled) {  // met at an earlier step: nothing after it was done
          stopped = true;
          steps_until_check_ = 1;
          break;
        }
      }
      if (!check_list()) recover();
    }
    // (after removals: uploaded, the next step checks; after a recovery, the test of its step)
    while (steps_to_sink_test() == 0 && apply_sinks() == Sinks::guard_stopped) recover();
    // The next check is steps_until_check_ steps after this one; the runs of steps also end at
    // the steps that test the sinks.
    const std::uint64_t to_sinks = steps_to_sink_test() ? steps_to_sink_test() : kSinkEvery;
    const std::uint64_t units = std::min<std::uint64_t>({steps_until_check_, max_steps - cur, to_sinks});
    if (units == 0) {
      if (entries_ready()) ++entry_passes_;
      if (fixed_sums_) ++fixed_passes_;
      second_half();
      ++forces_on_list_;
      // The drifts since the last check were within half the skin, or the guard stopped the
      // device after one (one wait per advance): before the host reports the steps made.
      if (guard_stopped_now()) {
        recover();
        checked = true;
        continue;
      }
      break;
    }
    run_units(static_cast<std::uint32_t>(units));
    tick(units);
    steps_until_check_ -= static_cast<std::uint32_t>(units - 1);
    cur += units;
  }
  r.steps = max_steps;
  if (settle_active_) {
    if (!stopped) poll_settle();
    r.steps = settle_host_.k - k0;
    r.below = settle_host_.below;
    r.settled = settle_host_.settled != 0;
    if (r.steps < cur) steps_until_check_ = 1;  // steps made no moves after the criterion was met: check at the next
  }
  // The host clock after the steps made, with the same additions as one step() at a time.
  host_.set_step_count(step0);
  host_.set_time_s(t0);
  tick(r.steps);
  if (profile_.on) {
    System::wait();
    profile_.advance_s += since(clock0);
    profile_.steps += r.steps;
  }
  return r;
}

inline std::string Engine::profile_report() const {
  if (!profile_.on || profile_.steps == 0) return {};
  const double steps = static_cast<double>(profile_.steps);
  auto fmt = [](double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.2f", v);
    return std::string(b);
  };
  const double other = profile_.advance_s - profile_.units_s - profile_.checks_s - profile_.builds_s;
  std::string r = "GPU profile (BIODEM_GPU_PROFILE=1), us per step over " + std::to_string(profile_.steps) +
                  " steps: " + fmt(1e6 * profile_.advance_s / steps) + " in all = step kernels " +
                  fmt(1e6 * profile_.units_s / steps) + " (" + std::to_string(profile_.units) + " steps between checks) + list checks " +
                  fmt(1e6 * profile_.checks_s / steps) + " (" + std::to_string(profile_.checks) + ", " +
                  fmt(profile_.checks ? 1e6 * profile_.checks_s / static_cast<double>(profile_.checks) : 0.0) +
                  " us each) + list builds " + fmt(1e6 * profile_.builds_s / steps) + " (" +
                  std::to_string(profile_.builds) + ", " +
                  fmt(profile_.builds ? 1e6 * profile_.builds_s / static_cast<double>(profile_.builds) : 0.0) +
                  " us each) + the rest " + fmt(1e6 * other / steps) + " (steps next to a check, settle polls)";
  return r;
}

inline Motion Engine::motion_now() {
  return thrust::transform_reduce(exec(), thrust::counting_iterator<std::uint32_t>(0),
                                  thrust::counting_iterator<std::uint32_t>(ns()), motion_of_sphere(), Motion{},
                                  MotionMax{});
}

inline void Engine::check_motion(const Motion& m, std::uint32_t lag) {
  if (m.unmirrored != 0.0) throw_unmirrored();
  const double half_skin = 0.5 * skin_;
  const double moved = std::sqrt(m.disp2);
  if (moved >= 1e150) {
    check_finite();  // throws, naming the sphere (when the motion read is of now: see below)
    if (lag) throw Error("GPU engine: a sphere's position became non-finite by t = " + std::to_string(host_.time_s()) +
                         " s: the simulation became unstable (is [run].dt_s too large?" + fixed_range_hint() + ")");
  }
  // (With the list guard on, a motion past half the skin at positions the list gave forces at
  // is one the guard stopped at: the callers recover before this.)
  if (!guard_on_ && moved > half_skin && (lag > 0 || forces_on_list_ > 1)) {
    char buf[256];  // (%g: sub-micrometre skins and moves keep their digits)
    std::snprintf(buf, sizeof buf,
                  "GPU engine: a sphere moved %.6g m since the last neighbour-list build, more than half the skin "
                  "(%.6g m), by a list check at most %u steps before t = %.9g s",
                  moved, half_skin, lag, host_.time_s());
    throw Error(std::string(buf) + ": contacts may have been missed; rerun with a larger [run] skin_m or a smaller dt_s");
  }
}

// lost_particles = "stop": the motion read of the list check bounds the sphere centres (their
// box, their largest distance from the drum axis). A body the host's rule finds lost has every
// sphere within its bounding radius rb of its centre, so past the mantle radius R (its centre
// beyond R + rb), below or above the end plates' planes, or within rb of a box face: only then
// are the bodies counted on the device (BodyMayBeLost), and only when one may be lost is the
// state downloaded for the host's test, which stops the run naming it. (Before 2026-11-28 the
// box alone was tested, against R + 2 rb per axis and a box grown by rb: a body that left a box
// by less than rb, or the drum at 45 degrees, and came back between samples went unnoticed.)
inline void Engine::check_lost(const Motion& m) {
  const sim::LostRegion& r = host_.lost_region();
  if (r.kind == sim::LostRegion::Kind::None || r.remove) return;  // (remove: apply_sinks)
  if (nb() == 0) return;
  double rb = 0.0;
  for (const auto& t : host_.templates()) rb = std::max(rb, t.bounding_radius_m);
  const Box& box = m.box;
  bool out = false;
  if (r.kind == sim::LostRegion::Kind::Drum) {
    out = m.radial2 > r.radius_m * r.radius_m;
    if (!r.periodic_z) out = out || box.lo.z < r.z0_m || box.hi.z > r.z1_m;
  } else {
    for (int k = 0; k < 3; ++k)
      if (!r.box_periodic[k]) out = out || box.lo[k] < r.min_m[k] + rb || box.hi[k] > r.max_m[k] - rb;
  }
  if (!out) return;
  const std::uint32_t may_be_lost = thrust::transform_reduce(
      exec(), thrust::counting_iterator<std::uint32_t>(0), thrust::counting_iterator<std::uint32_t>(nb()),
      BodyMayBeLost{raw<Vec3>(b_pos_), device_lost_region()}, 0u, thrust::plus<std::uint32_t>());
  if (may_be_lost == 0) return;
  download(false);
  host_.check_lost_bodies();  // throws, naming the body
}

inline DeviceLostRegion Engine::device_lost_region() const {
  const sim::LostRegion& r = host_.lost_region();
  DeviceLostRegion d;
  d.drum = r.kind == sim::LostRegion::Kind::Drum ? 1u : 0u;
  d.radius_m = r.radius_m;
  d.z0_m = r.z0_m;
  d.z1_m = r.z1_m;
  d.periodic_z = r.periodic_z ? 1u : 0u;
  d.min_m = r.min_m;
  d.max_m = r.max_m;
  for (int a = 0; a < 3; ++a) d.periodic[a] = r.box_periodic[a] ? 1u : 0u;
  d.rb_min = 1e300;
  for (const auto& t : host_.templates()) d.rb_min = std::min(d.rb_min, t.bounding_radius_m);
  if (host_.templates().empty()) d.rb_min = 0.0;
  return d;
}

inline Engine::Sinks Engine::apply_sinks() {
  const auto& sinks = host_.sinks();
  if ((sinks.empty() && !removes_lost()) || nb() == 0) return Sinks::none;
  ++sink_tests_;
  auto count = [this](const auto& f) {
    return thrust::transform_reduce(exec(), thrust::counting_iterator<std::uint32_t>(0),
                                    thrust::counting_iterator<std::uint32_t>(nb()), f, 0u,
                                    thrust::plus<std::uint32_t>());
  };
  std::uint32_t inside = 0;
  if (!sinks.empty()) {
    if (sinks_.size() != sinks.size()) to_device(sinks_, sinks);
    inside += count(BodyInSink{raw<Vec3>(b_pos_), raw<sim::SinkSpec>(sinks_), static_cast<std::uint32_t>(sinks_.size())});
  }
  if (removes_lost()) inside += count(BodyMayBeLost{raw<Vec3>(b_pos_), device_lost_region()});
  if (inside == 0) return Sinks::none;  // (of a state the guard may have stopped: tested again after its recovery)
  if (guard_stopped_now()) return Sinks::guard_stopped;
  // The device clock of the translating walls is that of the last step's forces, one step behind
  // the host clock here (after a drift, before the forces): kept across the upload.
  std::vector<double> clock;
  if (n_moving_walls_) to_host(clock, wall_clock_);
  // In a criterion phase, the settle state of now (the step before this one, as at a check),
  // which the upload writes back: the one last read may be steps old. Once the criterion is
  // met, the steps after it do nothing (the next check ends the run of steps): nor does this.
  if (settle_active_) {
    poll_settle();
    if (settle_host_.settled) return Sinks::none;
  }
  download(true, true);
  const std::size_t before = host_.bodies().size();
  host_.apply_sinks();
  if (removes_lost()) host_.check_lost_bodies();  // (removes and counts them)
  if (host_.bodies().size() == before) return Sinks::none;  // (a body between the radii: kept, nothing to upload)
  // The kernel set chosen by timing stays: a few bodies fewer do not change which set is the
  // fastest, and an upload would time them all again (a bulk test removes bodies hundreds of
  // times). A timing under way starts again.
  const TimedChoice kept = tuning_;
  const std::uint64_t kept_since = since_choice_;
  upload();
  if (timed_choice() && !kept.under_way()) {
    tuning_ = kept;
    since_choice_ = kept_since;
  }
  forces_on_list_ = 0;  // (the host's forces are of the step before: none yet at the new list's positions)
  if (n_moving_walls_) to_device(wall_clock_, clock);
  ++sink_removals_;
  return Sinks::removed;
}

inline bool Engine::check_list() {
  steps_until_check_ = check_every_;
  if (ns() == 0) return true;
  if (profile_.on) System::wait();  // (the step before it, not the check)
  const auto t0 = Clock::now();
  // The motion queued before the last step of the steps just launched (one step old, normally
  // complete by the time the host gets here while that step still runs: no wait), or, first
  // after an upload, the motion of now.
  bool lagged = motion_queued_;
  Motion m;
  if (lagged) {
    try {
      m = motion_.get();
    } catch (const DeviceFault&) {  // a kernel faulted: nothing can go on (no fallback line)
      throw;
    } catch (const Error& e) {
      queued_checks_ = false;
      invalidate_graphs();
      std::fprintf(stderr, "biodem: %s; the list checks wait for their reduction for the rest of the run\n", e.what());
      lagged = false;
    }
  }
  if (!lagged) m = motion_now();
  // The list guard: a kernel stopped after a drift past half the skin, or, in a motion queued
  // before the last step, the drift before it passed (whose forces then stopped): the device
  // stopped there. (In the motion of now, a flag of the last drift alone: no forces followed, and
  // the rule below rebuilds the list, as the CPU engine does.)
  if (m.guard_halted >= 2.0 || (lagged && m.guard_halted != 0.0)) {
    motion_queued_ = false;
    return false;
  }
  // No flag, yet a sphere past half the skin (the guard's own test, set_motion; with a margin of
  // 1e-12 for a squared distance that another kernel's contraction rounds otherwise): a drift
  // that the guard did not see. Never expected; stops the run rather than going on with the list.
  if (guard_on_ && m.guard_halted == 0.0 && !(m.disp2 <= 0.25 * skin_ * skin_ * (1.0 + 1e-12)))
    throw InternalError("internal: GPU engine: a sphere moved past half the skin without the list guard's flag (t = " +
                        std::to_string(host_.time_s()) + " s)");
  // Every drift before the one of now was within half the skin (or the motion would say so): the
  // runs of steps before the last can no longer hold the drift the guard stops at.
  if (runs_since_check_.size() > 1) runs_since_check_.erase(runs_since_check_.begin(), runs_since_check_.end() - 1);
  const std::uint32_t lag =
      lagged ? static_cast<std::uint32_t>(std::min<std::uint64_t>(drifts_ - motion_drifts_, 1u << 20)) : 0;
  motion_queued_ = false;
  if (lagged) ++waitless_checks_;
  check_motion(m, lag);
  check_lost(m);
  const double half_skin = 0.5 * skin_;
  // Until the next check, k steps later, a sphere moves at most k dt v; twice the largest speed
  // allows for acceleration in between. The motion read is `lag` steps old: those steps count
  // too. Rebuild if a sphere could pass half the skin before the next check, and check sooner
  // than check_every_ steps when even a fresh list would not last.
  double per_step = 2.0 * dt_ * std::sqrt(m.speed2);
  double room = half_skin - std::sqrt(m.disp2) - static_cast<double>(lag) * per_step;
  if (profile_.on) {
    profile_.checks_s += since(t0);
    ++profile_.checks;
  }
  if (room < check_every_ * per_step) {
    const auto t1 = Clock::now();
    // With the motion read one step old (lag 1), that step's positions are the last the old
    // list was used at (the positions of now get their forces with the new list), so the check
    // above covered the old list to its end, and the build goes on with that motion's box,
    // without a reduction and a wait of its own: a sphere that has left the box since is put in
    // the nearest edge cell (CellOf clamps), which keeps every pair within the cut-off in
    // neighbouring cells, so the rows are the same as with the box of now (and the results: they
    // do not depend on the grid); a position that became non-finite since is kept out of every
    // row (the cut-off test fails) and stops the run at the next check. The next check is set by
    // that speed, with the factor 2 for acceleration. With an older motion (lag 2 or more: a run
    // of steps that ended between two checks made a step with the old list that no queued
    // motion saw), the motion of now is reduced and checked first, as every rebuild did before.
    if (lagged && lag > 1) {
      m = motion_now();
      if (m.guard_halted >= 2.0) return false;
      check_motion(m, 0);
      per_step = 2.0 * dt_ * std::sqrt(m.speed2);
    }
    build_list(&m.box);
    forces_on_list_ = 0;
    room = half_skin;
    if (profile_.on) {
      System::wait();
      profile_.builds_s += since(t1);
      ++profile_.builds;
    }
  }
  steps_until_check_ = steps_to_next_check(room, per_step);
  return true;
}

inline std::uint64_t Engine::guard_take_back() {
  std::vector<StepFlags> f;
  to_host(f, guard_);  // (a wait: the device has stopped, the launches after the drift do nothing)
  const std::uint64_t made = guard_base_ + f[0].drifts;
  if (made > drifts_)
    throw InternalError("internal: GPU engine: the device made " + std::to_string(made) + " drifts, the host launched " +
                        std::to_string(drifts_));
  const std::uint64_t back = drifts_ - made;
  // The drift the device stopped after wrote the second motion buffer when it was the drift of
  // an even unit of a run of ForcesKickDrift units (two buffers); the run's copy back to the
  // first buffer (odd runs) went on only after its last unit.
  bool copy = false;
  for (const RunLaunched& r : runs_since_check_)
    if (made > r.first_drift && made <= r.first_drift + r.units) {
      const std::uint64_t j = made - r.first_drift - 1;
      copy = r.two_buffers && j % 2 == 0 && !(r.units % 2 == 1 && j + 1 == r.units);
    }
  if (copy)
    launch(ns(), CopySphereMotion{raw<Vec3>(s_pos2_), raw<Vec3>(s_vel2_), raw<Vec3>(s_omega2_), raw<Vec3>(s_pos_),
                                  raw<Vec3>(s_vel_), raw<Vec3>(s_omega_), records_ ? raw<SphereRecord>(s_rec2_) : nullptr,
                                  records_ ? raw<SphereRecord>(s_rec_) : nullptr, Halt{}});
  StepFlags clear;
  clear.drifts = f[0].drifts;
  guard_[0] = clear;
  drifts_ = made;
  runs_since_check_.clear();
  motion_queued_ = false;
  settle_queued_ = false;
  ++guard_halts_;
  // A timing of the kernel sets under way timed steps the device did not make: it starts again
  // (the steps since the last choice count only those made).
  if (tuning_under_way()) restart_tuning(false);
  else since_choice_ -= std::min(since_choice_, back);
  return back;
}

inline void Engine::guard_rebuild() {
  // The positions of now got no forces: a sphere past half the skin there is what the new list
  // is for (forces_on_list_ 0); a non-finite one, or a pair missing from a row, stops the run.
  forces_on_list_ = 0;
  Motion m = motion_now();
  check_motion(m, 0);
  check_lost(m);
  build_list(&m.box);
  forces_on_list_ = 0;
  steps_until_check_ = steps_to_next_check(0.5 * skin_, 2.0 * dt_ * std::sqrt(m.speed2));
}

inline bool Engine::guard_stopped_now() {
  if (!guard_on_ || ns() == 0) return false;
  std::vector<StepFlags> f;
  to_host(f, guard_);
  return f[0].stop != 0;
}

// Sums over the bodies in the host's body order (InHostOrder), whatever the device's order.
inline double Engine::kinetic_energy_j() {
  return thrust::transform_reduce(exec(), thrust::counting_iterator<std::uint32_t>(0),
                                  thrust::counting_iterator<std::uint32_t>(nb()),
                                  InHostOrder<BodyKineticEnergy>{{body_arrays()}, raw<std::uint32_t>(b_slot_)}, 0.0,
                                  thrust::plus<double>());
}

inline double Engine::translational_kinetic_energy_j() {
  return thrust::transform_reduce(
      exec(), thrust::counting_iterator<std::uint32_t>(0), thrust::counting_iterator<std::uint32_t>(nb()),
      InHostOrder<BodyTranslationalKineticEnergy>{{body_arrays()}, raw<std::uint32_t>(b_slot_)}, 0.0,
      thrust::plus<double>());
}

inline void Engine::download(bool history, bool mid_step) {
  // Every array in one batch of copies with one wait (on CUDA: into pinned host memory,
  // System::Staging), then into the host's arrays.
  auto& st = staging_;
  st.clear();
  auto add = [&st](auto& d) {
    using T = typename std::decay_t<decltype(d)>::value_type;
    return st.add(thrust::raw_pointer_cast(d.data()), d.size() * sizeof(T));
  };
  auto take = [&st](auto& h, std::size_t item, std::size_t n) {
    h.resize(n);
    if (n) std::memcpy(static_cast<void*>(h.data()), st.host(item), n * sizeof(h[0]));
  };
  // Device index d into host index to[d] (the device's storage order back to the host's).
  auto take_to = [&st](auto& h, std::size_t item, const std::vector<std::uint32_t>& to) {
    h.resize(to.size());
    const char* src = static_cast<const char*>(st.host(item));
    for (std::size_t d = 0; d < to.size(); ++d)
      std::memcpy(static_cast<void*>(&h[to[d]]), src + d * sizeof(h[0]), sizeof(h[0]));
  };
  const std::size_t n_b = nb(), n = ns();
  // A download with the history makes a host list at the positions of now (a checkpoint, the
  // end of the run; what a resume and the last outputs go on from): a sphere past half the skin
  // at positions the list gave forces at, which the next check would have stopped the run for,
  // stops it here. (Mid-step, the removal's upload checks the same.)
  if (history && !mid_step && n && builds_) check_motion(motion_now(), 0);
  if (history) mirror_history();  // (queued before the copies, on the same stream)
  const std::size_t i_missing = add(mirror_missing_);
  const std::size_t i_pos = add(b_pos_), i_vel = add(b_vel_), i_omega = add(b_omega_), i_l = add(b_l_), i_q = add(b_q_),
                    i_force = add(b_force_), i_torque = add(b_torque_), i_sforce = add(s_force_),
                    i_storque = add(s_torque_), i_contacts = add(s_contacts_), i_bhost = add(b_host_),
                    i_shost = add(s_host_);
  std::size_t i_rj = 0, i_rlen = 0, i_rt = 0, i_rh = 0, i_wh = 0, i_wt = 0;
  if (history) {
    i_rj = add(rows_.j);
    i_rlen = add(rows_.length);
    i_rt = add(rows_.touching);
    i_rh = add(rows_.history);
    i_wh = add(wall_history_);
    i_wt = add(wall_touching_);
  }
  st.run();
  if (*static_cast<const std::uint32_t*>(st.host(i_missing))) throw_unmirrored();
  std::vector<std::uint32_t> b_host, s_host;  // host index of each device body and sphere
  take(b_host, i_bhost, n_b);
  take(s_host, i_shost, n);
  auto& b = host_.bodies_mut();
  take_to(b.position_m, i_pos, b_host);
  take_to(b.velocity_m_s, i_vel, b_host);
  take_to(b.angular_velocity_rad_s, i_omega, b_host);
  take_to(b.angular_momentum_kg_m2_s, i_l, b_host);
  take_to(b.orientation, i_q, b_host);
  take_to(b.force_n, i_force, b_host);
  take_to(b.torque_n_m, i_torque, b_host);
  host_.mark_spheres_stale();
  auto& s = host_.spheres_mut();  // positions and velocities recomputed from the bodies (same formula)
  take_to(s.force_n, i_sforce, s_host);
  take_to(s.torque_n_m, i_storque, s_host);
  {
    std::vector<std::uint32_t> contacts;
    take(contacts, i_contacts, n);
    std::size_t total = 0;
    for (std::uint32_t c : contacts) total += c;
    host_.set_contact_count(total);
  }
  host_.update_wall_motion(host_.time_s());  // (the device moved its own copies of the translating walls)
  if (!history) return;

  // A fresh host list from the current positions, with the device's pair and wall history.
  std::vector<std::uint32_t> rj, rlen;
  std::vector<std::uint8_t> rt;
  std::vector<contact::ContactHistory> rh;
  take(rj, i_rj, rows_.j.size());
  take(rlen, i_rlen, rows_.length.size());
  take(rt, i_rt, rows_.touching.size());
  take(rh, i_rh, rows_.history.size());
  std::vector<contact::ContactHistory> wh;
  std::vector<std::uint8_t> wt;
  take(wh, i_wh, wall_history_.size());
  take(wt, i_wt, wall_touching_.size());
  st.clear();
  auto& L = host_.neighbor_list_mut();
  L.configure(domain_, skin_);
  const std::size_t host_builds = L.builds();
  L.build(s);
  // (a copy of the device's list, not a build of the run: the count a checkpoint keeps does not
  // depend on how many downloads were made, so a run stopped by a signal and resumed ends with
  // the checkpoint of a run that was not)
  L.restore_bookkeeping(std::vector<Vec3>(L.built_at()), host_builds);
  std::fill(L.touching.begin(), L.touching.end(), std::uint8_t{0});
  std::fill(L.history.begin(), L.history.end(), contact::ContactHistory{});
  // Device rows name device spheres: host sphere hi has device row i = dev[hi], and an entry
  // naming device sphere j names host sphere s_host[j].
  std::vector<std::uint32_t> dev(n);
  for (std::size_t i = 0; i < n; ++i) dev[s_host[i]] = static_cast<std::uint32_t>(i);
  std::size_t found = 0, touching = 0;
  for (std::size_t hi = 0; hi < n; ++hi) {
    const std::size_t i = dev[hi];
    for (std::uint32_t q = 0; q < rlen[i]; ++q)
      if (rt[q * n + i] && sid_host_[hi] < sid_host_[s_host[rj[q * n + i]]]) ++touching;
    for (std::uint32_t k = L.row_start[hi]; k < L.row_start[hi + 1]; ++k) {
      const std::uint32_t j = L.j[k];
      for (std::uint32_t q = 0; q < rlen[i]; ++q) {
        if (s_host[rj[q * n + i]] != j) continue;
        if (rt[q * n + i]) {
          contact::ContactHistory h = rh[q * n + i];
          if (sid_host_[hi] > sid_host_[j]) {
            h.xi = -h.xi;
            h.m_r = -h.m_r;
          }
          L.history[k] = h;
          L.touching[k] = 1;
          ++found;
        }
        break;
      }
    }
  }
  if (found != touching) {
    // Mid-step, a pair that moved beyond the host list's cut-off (r_i + r_j + skin) since the
    // last forces is dropped; one within it is missing for another reason: a bookkeeping fault.
    std::size_t near = touching - found;
    if (mid_step) {
      std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
      for (std::size_t hi = 0; hi < n; ++hi) {
        const std::size_t i = dev[hi];
        for (std::uint32_t q = 0; q < rlen[i]; ++q) {
          const std::uint32_t hj = s_host[rj[q * n + i]];
          if (rt[q * n + i] && sid_host_[hi] < sid_host_[hj]) pairs.emplace_back(static_cast<std::uint32_t>(hi), hj);
        }
      }
      near = neighbor::pairs_missing_within_cutoff(L, s, pairs);
    }
    if (near)
      throw InternalError("internal: " + std::to_string(near) +
                  " touching pairs of the device list are missing from the host list");
  }
  // Wall contacts: the touching ones with their history; the host adds the other candidates.
  sim::WallContacts wc;
  wc.start.assign(n + 1, 0);
  for (std::size_t hi = 0; hi < n; ++hi) {
    const std::size_t i = dev[hi];
    for (std::size_t w = 0; w < n_walls_; ++w)
      if (wt[w * n + i]) {
        wc.wall.push_back(static_cast<std::uint32_t>(w));
        wc.history.push_back(wh[w * n + i]);
        wc.touching.push_back(1);
      }
    wc.start[hi + 1] = static_cast<std::uint32_t>(wc.wall.size());
  }
  host_.wall_contacts() = std::move(wc);
  host_.restore_after_checkpoint(host_.time_s(), host_.step_count(), host_.drum_rotating(), skin_, L.built_at(),
                                 L.builds());
  host_.refresh_wall_candidates();
}

}  // namespace biodem::gpu::BIODEM_GPU_NS
