// Simulation: the time step (sim/simulation.hpp, docs/architecture.md section 3): the thread
// team's job (drift, pair rows, gather, walls, body sums, kick), the work chunks, and the
// per-sphere gather with the wall contacts. The pair rows are in pair_pass.cpp.
#include "sim/simulation.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>

#include "core/error.hpp"
#include "core/parallel.hpp"
#include "core/spin_team.hpp"
#include "integrate/rigid_rotation.hpp"
#include "integrate/velocity_verlet.hpp"
#include "sim/body_lanes.hpp"

#include <omp.h>

namespace biodem::sim {

namespace {
using Clock = std::chrono::steady_clock;
/// Chunks of one pass handed out to the team: thread t starts with its home range of chunks
/// (t/T to (t+1)/T of them, in order: on a quiet machine each thread keeps its own data in its
/// cache), then takes what is left of the others' ranges. A thread that is slowed down (a vCPU
/// that shares its core on a virtual machine) thus loses its chunks to the others instead of
/// holding up the barrier. Which thread runs a chunk changes nothing in the results.
class ChunkCursors {
 public:
  ChunkCursors(int threads, int chunks) : cursors_(static_cast<std::size_t>(std::max(threads, 1))) {
    const int t = std::max(threads, 1);
    for (int r = 0; r < t; ++r) {
      cursors_[r].next.store(chunks * r / t, std::memory_order_relaxed);
      cursors_[r].end = chunks * (r + 1) / t;
    }
  }
  template <class F>
  void for_each(int me, int team_size, F&& f) {
    const int ranges = static_cast<int>(cursors_.size());
    for (int r = 0; r < ranges; ++r) {
      Cursor& c = cursors_[(me + r) % ranges];
      for (int k = c.next.fetch_add(1, std::memory_order_relaxed); k < c.end;
           k = c.next.fetch_add(1, std::memory_order_relaxed))
        f(k);
    }
    (void)team_size;
  }

 private:
  struct alignas(64) Cursor {
    std::atomic<int> next{0};
    int end = 0;
  };
  std::vector<Cursor> cursors_;
};

/// One thread's tallies in a step (summed after the team's job, in thread order).
struct alignas(64) PerThread {
  std::size_t pairs = 0, walls = 0;
  double busy_s = 0.0;
};
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// Adds sphere i's share of the entries where it is the j side (rows in ascending order):
/// -force_i and +torque_j.
inline void add_reverse_entries(const neighbor::VerletList& L, std::size_t i, Vec3& f, Vec3& t) {
  for (std::uint32_t q = L.rev_start[i]; q < L.rev_start[i + 1]; ++q) {
    const std::uint32_t k = L.rev_entry[q];
    f -= L.force_i[k];
    t += L.torque_j[k];
  }
}

/// A wall slot whose sphere no longer touches the wall: its history is cleared.
inline void release_wall_slot(WallContacts& wc, std::uint32_t slot) {
  if (wc.touching[slot]) {
    wc.touching[slot] = 0;
    wc.history[slot] = {};
  }
}
}  // namespace

void Simulation::require_not_ahead() const {
  if (ahead_)
    throw InternalError("internal error: the simulation state was accessed between step(true) and the next step");
}

void Simulation::step(bool next_follows) {
  if (ahead_ && (!forces_valid_ || !list_valid_)) require_not_ahead();  // changed in between: throws
  if (!forces_valid_ || !list_valid_) refresh();
  const Clock::time_point t0 = profile_on_ ? Clock::now() : Clock::time_point{};
  update_wall_motion(time_s_ + dt_s_);
  // Common case, one parallel region: drift (unless the last step did it ahead), and unless the
  // list must be rebuilt or a body entered a sink, the forces and the second kick too (and with
  // next_follows the next step's drift). A rebuild or a sink (which removes the drifted bodies
  // serially) leaves the region after the drift; the rest of the step then runs as separate
  // passes. (Before 2026-11-28 a scene with sinks ran every step as separate passes, the drift
  // its own: 8-10 % slower on the small glass drum with a sink, 2 threads, with the same bits.)
  const bool ahead_next = next_follows;
  if (!step_in_one_region(ahead_next)) {  // drifted, and a rebuild is due (or a body is in a sink)
    const Clock::time_point t1 = profile_on_ ? Clock::now() : Clock::time_point{};
    check_finite_bodies();  // (before a sink could take an infinite position for one inside it)
    apply_sinks();
    check_lost_bodies();  // throws, or removes the lost bodies, before they enter the cell grid
    if (sort_every_builds_ && list_.builds() % sort_every_builds_ == 0) reorder_spatially();
    rebuild_neighbors();
    if (profile_on_) ++profile_.builds;
    if (profile_on_) profile_.list_s += seconds_since(t1);
    forces_and_kick(true, ahead_next);
  }
  // Sphere velocities at the full step are refreshed lazily, when someone reads the spheres
  // (outputs, diagnostics); the next step refreshes them anyway.
  spheres_stale_ = true;
  time_s_ += dt_s_;
  ++steps_;
  if (profile_on_) {
    profile_.step_s += seconds_since(t0);
    ++profile_.steps;
  }
}

int Simulation::drift_bodies(std::size_t b0, std::size_t b1, bool have_built, double limit2) {
  return advance_bodies<false>(b0, b1, have_built, limit2);
}

template <bool KickFirst>
int Simulation::advance_bodies(std::size_t b0, std::size_t b1, bool have_built, double limit2) {
  // With KickFirst: each body's force and torque sums and the second half kick of this step
  // (the operations of reduce_and_kick), then, as without: the first half kick of the next step,
  // the drift, the body's spheres placed, and the list displacement test. One pass, with a
  // body's values kept in registers from one part to the next: the same operations as
  // reduce_and_kick followed by drift_bodies, so the same bits.
  const double h = 0.5 * dt_s_, dt = dt_s_;
  const std::vector<Vec3>& built = list_.built_at();
  int moved = 0;
  auto test = [&](std::uint32_t s0, std::uint32_t s1) {
    if (have_built)
      for (std::uint32_t s = s0; s < s1; ++s)
        if (!(norm2(spheres_.position_m[s] - built[s]) <= limit2)) moved = 1;  // NaN also triggers a (failing) build
  };
  auto place_and_test = [&](std::size_t b) {
    place_spheres_of(b);
    test(bodies_.first_sphere[b], bodies_.first_sphere[b] + bodies_.sphere_count[b]);
  };
  // Clumps turn by the free-rotor splitting, kGroup at a time (free_rotation_steps: the same bits
  // as one at a time, with the bodies' dependent chains overlapping). A group that is not full is
  // padded with copies of its last body, whose results are dropped, so every body goes through
  // the same code whatever the blocks' cuts.
  constexpr int kGroup = 4;
  std::size_t waiting[kGroup];
  int n_waiting = 0;
  auto turn_waiting = [&] {
    Quat q[kGroup];
    Vec3 l[kGroup], inertia[kGroup], omega[kGroup];
    for (int g = 0; g < kGroup; ++g) {
      const std::size_t b = waiting[std::min(g, n_waiting - 1)];
      q[g] = bodies_.orientation[b];
      l[g] = bodies_.angular_momentum_kg_m2_s[b];
      inertia[g] = bodies_.inertia_kg_m2[b];
    }
    integrate::free_rotation_steps<kGroup>(q, l, inertia, dt, omega);
    for (int g = 0; g < n_waiting; ++g) {
      const std::size_t b = waiting[g];
      bodies_.orientation[b] = q[g];
      bodies_.angular_velocity_rad_s[b] = omega[g];
      place_and_test(b);
    }
    n_waiting = 0;
  };
  // A single sphere at its body's centre with equal moments (spins_as_sphere, the glass beads'
  // bodies): the same operations as the general path below, on pointers taken once (the
  // general path reloads each array's address at each access), without the angular momentum
  // (unused by such a body) and without the clump branches.
  const std::uint32_t* const first = bodies_.first_sphere.data();
  const std::uint32_t* const count = bodies_.sphere_count.data();
  const double* const mass_of = bodies_.mass_kg.data();
  const Vec3* const inertia_of = bodies_.inertia_kg_m2.data();
  Vec3* const body_x = bodies_.position_m.data();
  Vec3* const body_v = bodies_.velocity_m_s.data();
  Vec3* const body_w = bodies_.angular_velocity_rad_s.data();
  Vec3* const body_f = bodies_.force_n.data();
  Vec3* const body_t = bodies_.torque_n_m.data();
  const Vec3* const sphere_f = spheres_.force_n.data();
  const Vec3* const sphere_t = spheres_.torque_n_m.data();
  const Vec3* const offset = spheres_.offset_body_m.data();
  Vec3* const sphere_x = spheres_.position_m.data();
  Vec3* const sphere_v = spheres_.velocity_m_s.data();
  Vec3* const sphere_w = spheres_.angular_velocity_rad_s.data();
  const Vec3* const built_x = built.data();
  const Vec3 gravity = gravity_;
  auto single_sphere = [&](std::size_t b) {
    return integrate::spins_as_sphere(count[b], inertia_of[b]) && offset[first[b]] == Vec3{};
  };
  // Runs of eight (four) such bodies owning as many consecutive spheres go through AVX-512F
  // (AVX2) lanes when the pair kernel has 8 (4) lanes (sim/body_lanes.hpp: the same
  // operations per lane as the scalar path below).
  // Runs of eight (four) clumps of n spheres each, owning 8n (4n) consecutive spheres (the
  // needles), go through the same lanes (the same operations per lane as this path's clump
  // branch and turn_waiting).
  int (*lanes)(const BodyLaneArrays&, std::size_t) = nullptr;
  int (*clump_lanes)(const BodyLaneArrays&, std::size_t, std::uint32_t) = nullptr;
  std::size_t width = 1;
#if defined(BIODEM_X86_LANES)
  if (pair_kernel_ == PairKernel::Lanes8) {
    lanes = &advance_sphere_bodies_lanes8<KickFirst>;
    clump_lanes = &advance_clump_bodies_lanes8<KickFirst>;
    width = 8;
  } else if (pair_kernel_ == PairKernel::Lanes4) {
    lanes = &advance_sphere_bodies_lanes4<KickFirst>;
    clump_lanes = &advance_clump_bodies_lanes4<KickFirst>;
    width = 4;
  }
#endif
  BodyLaneArrays arrays{first,    mass_of,  inertia_of, body_x,   body_v,  body_w,  body_f,  body_t,
                        sphere_f, sphere_t, sphere_x,   sphere_v, sphere_w, built_x, gravity, h,
                        dt,       limit2,   have_built};
  arrays.orientation = bodies_.orientation.data();
  arrays.body_l = bodies_.angular_momentum_kg_m2_s.data();
  arrays.offset_body = offset;
  for (std::size_t b = b0; b < b1; ++b) {
    if (lanes != nullptr && b + width <= b1) {
      const std::uint32_t n = count[b];
      if (n >= 2) {
        bool run = first[b + width - 1] - first[b] == (width - 1) * n;
        for (std::size_t k = 1; k < width && run; ++k) run = count[b + k] == n;
        if (run) {
          moved |= clump_lanes(arrays, b, n);
          b += width - 1;
          continue;
        }
      } else {
        bool all = first[b + width - 1] - first[b] == width - 1;
        for (std::size_t k = 0; k < width && all; ++k) all = single_sphere(b + k);
        if (all) {
          moved |= lanes(arrays, b);
          b += width - 1;
          continue;
        }
      }
    }
    const std::uint32_t s0 = first[b], ns = count[b];
    const double mass = mass_of[b];
    const Vec3 inertia = inertia_of[b];
    if (integrate::spins_as_sphere(ns, inertia) && offset[s0] == Vec3{}) {
      Vec3 x = body_x[b], v = body_v[b], w = body_w[b], f, t;
      if constexpr (KickFirst) {  // reduce_and_kick's operations for one sphere
        const Vec3 fs = sphere_f[s0];
        f = mass * gravity;
        f += fs;
        t += sphere_t[s0] + cross(sphere_x[s0] - x, fs);
        body_f[b] = f;
        body_t[b] = t;
        v += (h / mass) * f;  // integrate::half_kick
        w += (h / inertia.x) * t;
      } else {
        f = body_f[b];
        t = body_t[b];
      }
      const double inv_m = 1.0 / mass;  // integrate::kick_and_drift_but_turn
      v += (h * inv_m) * f;
      x += dt * v;
      w += (h / inertia.x) * t;
      body_x[b] = x;
      body_v[b] = v;
      body_w[b] = w;
      sphere_x[s0] = x;  // place_spheres_of's first case
      sphere_v[s0] = v;
      sphere_w[s0] = w;
      if (have_built && !(norm2(x - built_x[s0]) <= limit2)) moved = 1;
      continue;
    }
    Vec3 x = bodies_.position_m[b], v = bodies_.velocity_m_s[b], w = bodies_.angular_velocity_rad_s[b],
         l = bodies_.angular_momentum_kg_m2_s[b], f, t;
    if constexpr (KickFirst) {
      f = mass * gravity_;
      for (std::uint32_t s = s0; s < s0 + ns; ++s) {
        f += spheres_.force_n[s];
        t += spheres_.torque_n_m[s] + cross(spheres_.position_m[s] - x, spheres_.force_n[s]);
      }
      bodies_.force_n[b] = f;
      bodies_.torque_n_m[b] = t;
      if (integrate::spins_as_sphere(ns, inertia)) {  // a single sphere off its body's centre
        integrate::half_kick(v, w, l, bodies_.orientation[b], mass, inertia, ns, f, t, h);
      } else {
        // half_kick's clump branch less the lab angular velocity it derives from l (two
        // rotations and three divisions), which the turn below replaces unread (as
        // integrate::half_kick_then_kick_and_drift).
        v += (h / mass) * f;
        l += h * t;
      }
    } else {
      f = bodies_.force_n[b];
      t = bodies_.torque_n_m[b];
    }
    const bool turned = integrate::kick_and_drift_but_turn(x, v, w, l, mass, inertia, ns, f, t, h, dt);
    bodies_.position_m[b] = x;
    bodies_.velocity_m_s[b] = v;
    bodies_.angular_velocity_rad_s[b] = w;
    bodies_.angular_momentum_kg_m2_s[b] = l;
    if (turned) {  // a single sphere off its body's centre (the centred ones took the path above)
      place_and_test(b);
      continue;
    }
    waiting[n_waiting++] = b;
    if (n_waiting == kGroup) turn_waiting();
  }
  if (n_waiting > 0) turn_waiting();
  // A body whose centre the drift took into a sink leaves the step's parallel region as a
  // rebuild does: step() then removes it serially (apply_sinks) and rebuilds the list, before
  // the forces, as the separate drift pass did for every step of a scene with sinks.
  if (!sinks_.empty())
    for (std::size_t b = b0; b < b1; ++b)
      for (const SinkSpec& k : sinks_)
        if (k.contains(bodies_.position_m[b])) moved = 1;
  return moved;
}

bool Simulation::step_in_one_region(bool ahead_next) {
  if (cohesion_)
    return rolling_ ? step_job<true, true>(true, true, ahead_next) : step_job<true, false>(true, true, ahead_next);
  return rolling_ ? step_job<false, true>(true, true, ahead_next) : step_job<false, false>(true, true, ahead_next);
}

template <bool Cohesion, bool Rolling>
bool Simulation::step_job(bool drift, bool kick, bool ahead_next) {
  // One job of the thread team. With drift: the drift of every chunk (unless the last step's
  // job did it ahead), a barrier, and every thread reads all chunks' displacement flags (so all
  // take the same branch); if a rebuild is due the job ends there (returns false: the bodies
  // have drifted). Then: pair rows, a barrier, gather, walls, body sums and (with kick) the
  // second half kick; with ahead_next, each chunk's bodies then get the next step's drift.
  ensure_work_blocks();
  const int blocks = static_cast<int>(block_body_.size()) - 1;
  const bool have_built = list_.built_at().size() == spheres_.size();
  const double limit2 = list_.rebuild_limit2();
  const bool drifted = drift && ahead_;
  if (drift) {
    block_moved_.assign(static_cast<std::size_t>(blocks), 0);
    if (drifted) block_moved_[0] = ahead_moved_;  // the flags of the drift made ahead
    ahead_ = false;
  }
  bool rebuild = false;
  const Clock::time_point t0 = profile_on_ ? Clock::now() : Clock::time_point{};
  double drift_end_s = 0.0, pair_end_s = 0.0;
  std::vector<PerThread> per(static_cast<std::size_t>(std::max(threads_, 1)));
  ChunkCursors drift_chunks(threads_, blocks), pair_chunks(threads_, blocks), gather_chunks(threads_, blocks);
  const PairPassData pass = pair_pass_data();
  if (ahead_next) ahead_moved_by_.assign(static_cast<std::size_t>(blocks), 0);
  team().run(threads_, [&](int me, int team_size) {
    if (drift) {
      if (!drifted) {
        drift_chunks.for_each(me, team_size, [&](int k) {
          block_moved_[k] = static_cast<std::uint8_t>(drift_bodies(block_body_[k], block_body_[k + 1], have_built, limit2));
        });
        team().barrier();
      }
      bool any = !have_built;
      for (int k = 0; k < blocks; ++k) any = any || block_moved_[k] != 0;
      if (me == 0) {
        rebuild = any;
        if (profile_on_) drift_end_s = seconds_since(t0);
      }
      if (any) return;
    }
    const Clock::time_point tp = profile_on_ ? Clock::now() : Clock::time_point{};
    pair_chunks.for_each(me, team_size, [&](int k) {
      const std::size_t b0 = block_body_[k], b1 = block_body_[k + 1];
      if (b0 == b1) return;
      per[me].pairs += sim::pair_rows<Cohesion, Rolling>(
          pair_kernel_, pass, bodies_.first_sphere[b0], bodies_.first_sphere[b1 - 1] + bodies_.sphere_count[b1 - 1]);
    });
    if (profile_on_) per[me].busy_s = seconds_since(tp);
    team().barrier();
    if (profile_on_ && me == 0) pair_end_s = seconds_since(t0);
    gather_chunks.for_each(me, team_size, [&](int k) {
      // In pieces of at most kGatherPiece bodies, so that a piece's data stay in the core's
      // cache from the gather to the drift (each body's operations are the same whatever the
      // pieces: the results do not depend on them).
      for (std::size_t p0 = block_body_[k], b1 = block_body_[k + 1]; p0 < b1; p0 += kGatherPiece) {
        const std::size_t p1 = std::min(b1, p0 + kGatherPiece);
        per[me].walls += gather_and_walls<Cohesion, Rolling>(
            bodies_.first_sphere[p0], bodies_.first_sphere[p1 - 1] + bodies_.sphere_count[p1 - 1]);
        // Sums and kick, and with ahead_next the next step's half kick, drift and placement of
        // the piece (the gather above read only the piece's own spheres, and the pair rows that
        // read the others' ended at the barrier).
        if (ahead_next)
          ahead_moved_by_[k] |= static_cast<std::uint8_t>(advance_bodies<true>(p0, p1, have_built, limit2));
        else
          reduce_and_kick(p0, p1, kick);
      }
    });
  });
  if (drift) {
    spheres_stale_ = false;
    if (profile_on_) profile_.drift_s += drift_end_s;
    if (rebuild) return false;  // left after the drift: no forces, no drift made ahead
  }
  if (ahead_next) {
    ahead_ = true;
    ahead_moved_ = false;
    for (std::uint8_t m : ahead_moved_by_) ahead_moved_ = ahead_moved_ || m != 0;
  }
  std::size_t pair_contacts = 0, wall_contacts = 0;
  double busy_s = 0.0;
  for (const PerThread& q : per) {
    pair_contacts += q.pairs;
    wall_contacts += q.walls;
    busy_s += q.busy_s;
  }
  contacts_ = pair_contacts + wall_contacts;
  if (profile_on_ && kick) {
    profile_.pairs_s += pair_end_s - drift_end_s;
    profile_.pairs_busy_s += busy_s / std::max(1, threads_);
    profile_.gather_s += seconds_since(t0) - pair_end_s;
  }
  return true;
}

void Simulation::ensure_work_blocks() {
  const std::size_t want = spheres_.size() >= kParallelThreshold ? static_cast<std::size_t>(std::max(1, omp_get_max_threads())) : 1;
  if (blocks_for_ != std::pair<std::size_t, std::size_t>{bodies_.size(), want}) update_work_blocks();
}

void Simulation::update_work_blocks() {
  // Cuts the bodies into one contiguous block per thread with about the same work: per sphere,
  // its list row and reverse entries, its wall candidates and a constant for the per-sphere
  // work. Bodies own contiguous spheres, so a block is also a contiguous range of spheres, and
  // the thread that evaluates a block's rows also gathers and integrates its bodies (the pair
  // results it reads were mostly written by itself). The cuts only decide who does what: the
  // result is the same for any cuts.
  const std::size_t nb = bodies_.size(), n = spheres_.size();
  const int threads = n >= kParallelThreshold ? std::max(1, omp_get_max_threads()) : 1;
  const int chunks = threads == 1 ? 1 : threads * kChunksPerThread;
  const bool rows_ok = list_.row_start.size() == n + 1 && list_.rev_start.size() == n + 1 &&
                       wall_contacts_.start.size() == n + 1;
  block_body_.assign(static_cast<std::size_t>(chunks) + 1, nb);
  block_body_[0] = 0;
  threads_ = threads;
  if (chunks == 1 || !rows_ok) {
    for (int t = 1; t < chunks; ++t) block_body_[t] = nb * t / chunks;
    blocks_for_ = {nb, static_cast<std::size_t>(threads)};
    return;
  }
  std::vector<double> prefix(nb + 1, 0.0);
  for (std::size_t b = 0; b < nb; ++b) {
    const std::uint32_t s0 = bodies_.first_sphere[b], s1 = s0 + bodies_.sphere_count[b];
    const double w = static_cast<double>(list_.row_start[s1] - list_.row_start[s0]) +
                     0.25 * static_cast<double>(list_.rev_start[s1] - list_.rev_start[s0]) +
                     static_cast<double>(wall_contacts_.start[s1] - wall_contacts_.start[s0]) +
                     1.0 * static_cast<double>(s1 - s0);
    prefix[b + 1] = prefix[b] + w;
  }
  for (int t = 1; t < chunks; ++t) {
    const double target = prefix[nb] * t / chunks;
    block_body_[t] = static_cast<std::size_t>(std::lower_bound(prefix.begin(), prefix.end(), target) - prefix.begin());
    block_body_[t] = std::clamp(block_body_[t], block_body_[t - 1], nb);
  }
  blocks_for_ = {nb, static_cast<std::size_t>(threads)};
}

PairPassData Simulation::pair_pass_data() {
  return make_pair_pass_data(spheres_, list_, pairs_, dt_s_, domain_.any_periodic());
}

void Simulation::forces_and_kick(bool kick, bool ahead_next) {
  if (cohesion_) rolling_ ? step_job<true, true>(false, kick, ahead_next) : step_job<true, false>(false, kick, ahead_next);
  else rolling_ ? step_job<false, true>(false, kick, ahead_next) : step_job<false, false>(false, kick, ahead_next);
}

template <bool Cohesion, bool Rolling>
std::size_t Simulation::gather_and_walls(std::size_t i0, std::size_t i1) {
  // Per sphere, in a fixed order: its own row's sum, the entries where it is the j side (rows in
  // ascending order), then its wall contacts.
  const auto& s = spheres_;
  const auto& L = list_;
  auto& wc = wall_contacts_;
  const double dt = dt_s_;
  std::size_t contacts = 0;
  if (const auto evaluate = wall_batch_evaluator<Cohesion, Rolling>(pair_kernel_))
    return gather_and_wall_batches<Cohesion, Rolling>(i0, i1, evaluate);
  for (std::size_t i = i0; i < i1; ++i) {
    Vec3 f = spheres_.force_n[i], t = spheres_.torque_n_m[i];
    add_reverse_entries(L, i, f, t);
    for (std::uint32_t slot = wc.start[i]; slot < wc.start[i + 1]; ++slot) {
      const WallSpec& ws = walls_[wc.wall[slot]];
      const double ri = s.radius_m[i];
      const walls::WallHit hit = walls::wall_hit(ws.geometry, s.position_m[i], ri);
      if (!hit.touching) {
        release_wall_slot(wc, slot);
        continue;
      }
      const Vec3 surface_point = s.position_m[i] - hit.gap_m * hit.normal;
      const Vec3 v_wall = walls::wall_velocity(ws.geometry, surface_point);
      // The wall's spin enters only EPSD2 (w_rel); "lab" drops it (LIGGGHTS 3.8.0 convention).
      const Vec3 w_wall = wall_rolling_lab_ ? Vec3{} : ws.geometry.angular_velocity_rad_s * ws.geometry.normal;
      const contact::ContactGeometry g = contact::sphere_wall_geometry(
          hit.normal, hit.gap_m, ri, s.body_mass_kg[i], s.velocity_m_s[i], s.angular_velocity_rad_s[i], v_wall, w_wall);
      const contact::PairParams& p = pairs_(s.material[i], ws.material);
      const double area = Cohesion ? contact::sjkr_area_sphere_wall(ri, hit.gap_m) : 0.0;
      const contact::ContactOutput out = contact::evaluate_contact<Cohesion, Rolling>(g, p, wc.history[slot], area, dt);
      wc.touching[slot] = 1;
      f += out.force_i;
      t += out.torque_i;
      ++contacts;
    }
    spheres_.force_n[i] = f;
    spheres_.torque_n_m[i] = t;
  }
  return contacts;
}

template <bool Cohesion, bool Rolling>
std::size_t Simulation::gather_and_wall_batches(std::size_t i0, std::size_t i1, void (*evaluate)(WallBatch&)) {
  // As gather_and_walls, with the touching wall contacts staged and evaluated in SIMD lanes (the
  // pair kernel's width): each sphere's sum (own row, then its j entries) is stored first, and
  // its wall contacts are added to it in slot order when their batch is evaluated, so every
  // sphere adds the same numbers in the same order as the scalar loop.
  const auto& s = spheres_;
  const auto& L = list_;
  auto& wc = wall_contacts_;
  using F = WallBatch;
  WallBatch b;
  b.spheres = &spheres_;
  b.dt_s = dt_s_;
  auto put3 = [&](int f, int k, const Vec3& v) {
    b.a[f][k] = v.x;
    b.a[f + 1][k] = v.y;
    b.a[f + 2][k] = v.z;
  };
  auto get3 = [&](int f, int k) { return Vec3{b.a[f][k], b.a[f + 1][k], b.a[f + 2][k]}; };
  auto flush = [&] {
    const int n = b.n;
    if (n == 0) return;
    for (int k = n; k % 8 != 0; ++k) {  // pad with copies of the last contact (results unused)
      for (int f = 0; f < F::kFields; ++f) b.a[f][k] = b.a[f][n - 1];
      b.i[k] = b.i[n - 1];
      b.slot[k] = b.slot[n - 1];
      b.params[k] = b.params[n - 1];
    }
    evaluate(b);
    for (int k = 0; k < n; ++k) {
      const std::uint32_t i = b.i[k], slot = b.slot[k];
      wc.touching[slot] = 1;
      wc.history[slot].xi = get3(F::Xix, k);
      if constexpr (Rolling) wc.history[slot].m_r = get3(F::Mrx, k);
      spheres_.force_n[i] += get3(F::Fx, k);
      spheres_.torque_n_m[i] += get3(F::Tix, k);
    }
    b.n = 0;
  };
  std::size_t contacts = 0;
  for (std::size_t i = i0; i < i1; ++i) {
    Vec3 f = spheres_.force_n[i], t = spheres_.torque_n_m[i];
    add_reverse_entries(L, i, f, t);
    spheres_.force_n[i] = f;
    spheres_.torque_n_m[i] = t;
    for (std::uint32_t slot = wc.start[i]; slot < wc.start[i + 1]; ++slot) {
      const WallSpec& ws = walls_[wc.wall[slot]];
      const double ri = s.radius_m[i];
      const walls::WallHit hit = walls::wall_hit(ws.geometry, s.position_m[i], ri);
      if (!hit.touching) {
        release_wall_slot(wc, slot);
        continue;
      }
      const Vec3 surface_point = s.position_m[i] - hit.gap_m * hit.normal;
      const int k = b.n;
      put3(F::Nx, k, hit.normal);
      b.a[F::Gap][k] = hit.gap_m;
      put3(F::Vwx, k, walls::wall_velocity(ws.geometry, surface_point));
      put3(F::Wwx, k, wall_rolling_lab_ ? Vec3{} : ws.geometry.angular_velocity_rad_s * ws.geometry.normal);
      put3(F::Xix, k, wc.history[slot].xi);
      if constexpr (Rolling) put3(F::Mrx, k, wc.history[slot].m_r);
      b.i[k] = static_cast<std::uint32_t>(i);
      b.slot[k] = slot;
      b.params[k] = &pairs_(s.material[i], ws.material);
      ++contacts;
      if (++b.n == F::kCapacity) flush();
    }
  }
  flush();
  return contacts;
}

void Simulation::reduce_and_kick(std::size_t b0, std::size_t b1, bool kick) {
  // Body force (with gravity) and torque about the centre of mass, then the second half kick.
  const double h = 0.5 * dt_s_;
  for (std::size_t b = b0; b < b1; ++b) {
    const std::uint32_t s0 = bodies_.first_sphere[b], ns = bodies_.sphere_count[b];
    Vec3 f = bodies_.mass_kg[b] * gravity_, t;
    for (std::uint32_t s = s0; s < s0 + ns; ++s) {
      f += spheres_.force_n[s];
      t += spheres_.torque_n_m[s] + cross(spheres_.position_m[s] - bodies_.position_m[b], spheres_.force_n[s]);
    }
    bodies_.force_n[b] = f;
    bodies_.torque_n_m[b] = t;
    if (!kick) continue;
    integrate::half_kick(bodies_.velocity_m_s[b], bodies_.angular_velocity_rad_s[b], bodies_.angular_momentum_kg_m2_s[b],
                         bodies_.orientation[b], bodies_.mass_kg[b], bodies_.inertia_kg_m2[b], ns, f, t, h);
  }
}
}  // namespace biodem::sim
