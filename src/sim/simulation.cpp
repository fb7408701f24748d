#include "sim/simulation.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cmath>

#include "core/error.hpp"
#include "core/parallel.hpp"
#include "core/spin_team.hpp"
#include "integrate/rigid_rotation.hpp"
#include "integrate/velocity_verlet.hpp"

#include <omp.h>

namespace biodem::sim {

Simulation::Simulation(std::vector<shapes::ClumpTemplate> templates, std::vector<double> material_density_kg_m3,
                       contact::PairTable pairs, double dt_s, Vec3 gravity_m_s2)
    : templates_(std::move(templates)),
      density_(std::move(material_density_kg_m3)),
      pairs_(std::move(pairs)),
      dt_s_(dt_s),
      gravity_(gravity_m_s2) {
  cohesion_ = pairs_.any_cohesion();
  rolling_ = pairs_.any_rolling();
  pair_kernel_ = pair_kernel_from_environment();
}

std::uint32_t Simulation::add_wall(const WallSpec& w) {
  walls_.push_back(w);
  wall_initial_point_m_.push_back(w.geometry.point_m);
  apply_drum_rotation();
  update_wall_motion(time_s_);
  list_valid_ = false;  // the candidate table is rebuilt with the neighbour list
  forces_valid_ = false;
  return static_cast<std::uint32_t>(walls_.size() - 1);
}

void Simulation::update_wall_motion(double t) {
  for (std::size_t k = 0; k < walls_.size(); ++k) {
    WallSpec& w = walls_[k];
    if (!w.translates()) continue;
    const double tau = std::clamp(t - w.move_start_s, 0.0, w.move_end_s - w.move_start_s);
    w.geometry.point_m = wall_initial_point_m_[k] + tau * w.translation_velocity_m_s;
    w.geometry.velocity_m_s = (t >= w.move_start_s && t < w.move_end_s) ? w.translation_velocity_m_s : Vec3{};
  }
}

void Simulation::apply_drum_rotation() {
  for (auto& w : walls_)
    if (w.drum_wall) w.geometry.angular_velocity_rad_s = drum_rotating_ ? w.drum_sign * drum_omega_ : 0.0;
}

std::uint32_t Simulation::add_body(const BodyInit& in) {
  if (in.shape >= templates_.size()) throw Error("add_body: unknown shape index");
  if (in.material >= density_.size()) throw Error("add_body: unknown material index");
  const auto& t = templates_[in.shape];
  const double rho = density_[in.material];
  const std::uint32_t b = static_cast<std::uint32_t>(bodies_.size());
  const double mass = rho * t.volume_m3;
  const Vec3 inertia = rho * t.principal_inertia_per_density_m5;
  bodies_.position_m.push_back(in.position_m);
  bodies_.velocity_m_s.push_back(in.velocity_m_s);
  bodies_.angular_velocity_rad_s.push_back(in.angular_velocity_rad_s);
  bodies_.orientation.push_back(normalized(in.orientation));
  bodies_.angular_momentum_kg_m2_s.push_back(
      integrate::angular_momentum_from_velocity(bodies_.orientation.back(), in.angular_velocity_rad_s, inertia));
  bodies_.mass_kg.push_back(mass);
  bodies_.inertia_kg_m2.push_back(inertia);
  bodies_.shape.push_back(in.shape);
  bodies_.id.push_back(b);
  bodies_.first_sphere.push_back(static_cast<std::uint32_t>(spheres_.size()));
  bodies_.sphere_count.push_back(static_cast<std::uint32_t>(t.sphere_count()));
  bodies_.force_n.push_back({});
  bodies_.torque_n_m.push_back({});
  for (std::size_t k = 0; k < t.sphere_count(); ++k) {
    spheres_.position_m.push_back(in.position_m + rotate(bodies_.orientation.back(), t.offsets_m[k]));
    spheres_.velocity_m_s.push_back({});
    spheres_.angular_velocity_rad_s.push_back({});
    spheres_.radius_m.push_back(t.radii_m[k]);
    spheres_.offset_body_m.push_back(t.offsets_m[k]);
    spheres_.body.push_back(b);
    spheres_.material.push_back(in.material);
    spheres_.body_mass_kg.push_back(mass);
    spheres_.force_n.push_back({});
    spheres_.torque_n_m.push_back({});
    wall_contacts_.start.push_back(wall_contacts_.start.back());  // no candidates until the next build
  }
  list_valid_ = false;
  forces_valid_ = false;
  return b;
}

void Simulation::place_spheres_of(std::size_t b) {
  const std::uint32_t s0 = bodies_.first_sphere[b], ns = bodies_.sphere_count[b];
  const Vec3 x = bodies_.position_m[b], v = bodies_.velocity_m_s[b], w = bodies_.angular_velocity_rad_s[b];
  if (ns == 1 && spheres_.offset_body_m[s0] == Vec3{}) {
    spheres_.position_m[s0] = x;
    spheres_.velocity_m_s[s0] = v;
    spheres_.angular_velocity_rad_s[s0] = w;
    return;
  }
  const Mat3 r = to_matrix(bodies_.orientation[b]);
  for (std::uint32_t s = s0; s < s0 + ns; ++s) {
    const Vec3 arm = r * spheres_.offset_body_m[s];
    spheres_.position_m[s] = x + arm;
    spheres_.velocity_m_s[s] = v + cross(w, arm);
    spheres_.angular_velocity_rad_s[s] = w;
  }
}

void Simulation::update_spheres_from_bodies() {
  spheres_stale_ = false;
  const std::size_t nb = bodies_.size();
#pragma omp parallel for proc_bind(close) schedule(static) if (nb >= kParallelThreshold)
  for (std::size_t b = 0; b < nb; ++b) place_spheres_of(b);
}

void Simulation::reorder_spatially() {
  const std::size_t nb = bodies_.size(), ns = spheres_.size();
  if (nb < 2) return;
  double r_max = 0.0;
  for (double r : spheres_.radius_m) r_max = std::max(r_max, r);
  Vec3 lo{1e300, 1e300, 1e300};
  for (const auto& x : bodies_.position_m)
    for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], x[k]);
  const double cell = 2.0 * r_max + skin_m_;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> key(nb);
  for (std::size_t b = 0; b < nb; ++b) {
    std::uint64_t c[3];
    for (int k = 0; k < 3; ++k)
      c[k] = static_cast<std::uint64_t>(std::min(2.0e6, std::floor((bodies_.position_m[b][k] - lo[k]) / cell)));
    key[b] = {(c[2] << 42) | (c[1] << 21) | c[0], static_cast<std::uint32_t>(b)};
  }
  std::sort(key.begin(), key.end());
  std::vector<std::uint32_t> new_of_old_body(nb), new_of_old_sphere(ns);
  for (std::size_t q = 0; q < nb; ++q) new_of_old_body[key[q].second] = static_cast<std::uint32_t>(q);

  std::vector<std::uint32_t> old_body_of_new(nb);
  for (std::size_t q = 0; q < nb; ++q) old_body_of_new[q] = key[q].second;
  state::BodyStore nbs = state::gather(bodies_, old_body_of_new);
  std::vector<std::uint32_t> old_sphere_of_new;
  old_sphere_of_new.reserve(ns);
  for (std::size_t q = 0; q < nb; ++q) {
    nbs.first_sphere[q] = static_cast<std::uint32_t>(old_sphere_of_new.size());
    const std::uint32_t s0 = bodies_.first_sphere[key[q].second];
    for (std::uint32_t s = s0; s < s0 + nbs.sphere_count[q]; ++s) {
      new_of_old_sphere[s] = static_cast<std::uint32_t>(old_sphere_of_new.size());
      old_sphere_of_new.push_back(s);
    }
  }
  state::SphereStore nss = state::gather(spheres_, old_sphere_of_new);
  for (std::size_t q = 0; q < ns; ++q) nss.body[q] = new_of_old_body[spheres_.body[old_sphere_of_new[q]]];
  WallContacts wc;
  wc.start.assign(ns + 1, 0);
  for (std::size_t q = 0; q < ns; ++q) {
    const std::uint32_t o = old_sphere_of_new[q];
    for (std::uint32_t k = wall_contacts_.start[o]; k < wall_contacts_.start[o + 1]; ++k) {
      wc.wall.push_back(wall_contacts_.wall[k]);
      wc.history.push_back(wall_contacts_.history[k]);
      wc.touching.push_back(wall_contacts_.touching[k]);
    }
    wc.start[q + 1] = static_cast<std::uint32_t>(wc.wall.size());
  }
  bodies_ = std::move(nbs);
  spheres_ = std::move(nss);
  wall_contacts_ = std::move(wc);
  list_.renumber(new_of_old_sphere);
}

void Simulation::apply_sinks() {
  if (sinks_.empty()) return;
  const std::size_t nb = bodies_.size();
  std::vector<std::uint8_t> flag(nb, 0);
  bool any = false;
  for (std::size_t b = 0; b < nb; ++b)
    for (const auto& k : sinks_)
      if (k.contains(bodies_.position_m[b])) {
        flag[b] = 1;
        any = true;
        break;
      }
  if (any) remove_bodies(flag);
}

void Simulation::check_lost_bodies() {
  if (lost_region_.kind == LostRegion::Kind::None) return;
  const LostRegion& r = lost_region_;
  const std::size_t nb = bodies_.size();
  std::vector<std::uint8_t> flag(nb, 0);
  std::size_t count = 0;
  for (std::size_t b = 0; b < nb; ++b) {
    const Vec3 x = bodies_.position_m[b];
    const double rb = templates_[bodies_.shape[b]].bounding_radius_m;
    bool lost = !(x.x == x.x && x.y == x.y && x.z == x.z);
    if (r.kind == LostRegion::Kind::Drum) {
      lost = lost || x.x * x.x + x.y * x.y > (r.radius_m + rb) * (r.radius_m + rb);
      if (!r.periodic_z) lost = lost || x.z < r.z0_m - rb || x.z > r.z1_m + rb;
    } else {
      for (int k = 0; k < 3; ++k) lost = lost || (!r.box_periodic[k] && (x[k] < r.min_m[k] || x[k] > r.max_m[k]));
    }
    if (!lost) continue;
    if (!r.remove) {
      char buf[256];
      std::snprintf(buf, sizeof buf, "body %u was lost at t = %.6g s: its centre (%.6g, %.6g, %.6g) m is outside the %s",
                    bodies_.id[b], time_s_, x.x, x.y, x.z, r.kind == LostRegion::Kind::Drum ? "drum" : r.box_name);
      throw Error(std::string(buf) + " (too large a time step, or an opening in the walls?); [run] lost_particles = \"remove\" removes such bodies instead");
    }
    flag[b] = 1;
    ++count;
  }
  if (count == 0) return;
  lost_bodies_ += count;
  remove_bodies(flag);
}

std::size_t Simulation::remove_bodies(const std::vector<std::uint8_t>& remove) {
  const std::size_t nb = bodies_.size(), ns = spheres_.size();
  constexpr std::uint32_t kGone = neighbor::VerletList::kRemoved;
  std::vector<std::uint32_t> keep_body, new_of_old_sphere(ns, kGone), old_sphere_of_new;
  for (std::size_t b = 0; b < nb; ++b) {
    if (b < remove.size() && remove[b]) {
      ++removed_bodies_;
      removed_mass_kg_ += bodies_.mass_kg[b];
      continue;
    }
    keep_body.push_back(static_cast<std::uint32_t>(b));
  }
  const std::size_t removed = nb - keep_body.size();
  if (removed == 0) return 0;
  state::BodyStore nbs = state::gather(bodies_, keep_body);
  for (std::size_t q = 0; q < keep_body.size(); ++q) {
    nbs.first_sphere[q] = static_cast<std::uint32_t>(old_sphere_of_new.size());
    const std::uint32_t s0 = bodies_.first_sphere[keep_body[q]];
    for (std::uint32_t s = s0; s < s0 + nbs.sphere_count[q]; ++s) {
      new_of_old_sphere[s] = static_cast<std::uint32_t>(old_sphere_of_new.size());
      old_sphere_of_new.push_back(s);
    }
  }
  const std::size_t ns_new = old_sphere_of_new.size();
  state::SphereStore nss = state::gather(spheres_, old_sphere_of_new);
  for (std::size_t q = 0; q < keep_body.size(); ++q)
    for (std::uint32_t s = nbs.first_sphere[q]; s < nbs.first_sphere[q] + nbs.sphere_count[q]; ++s)
      nss.body[s] = static_cast<std::uint32_t>(q);
  WallContacts wc;
  wc.start.assign(ns_new + 1, 0);
  const bool have_wc = wall_contacts_.start.size() == ns + 1;
  for (std::size_t q = 0; q < ns_new; ++q) {
    const std::uint32_t o = old_sphere_of_new[q];
    if (have_wc)
      for (std::uint32_t k = wall_contacts_.start[o]; k < wall_contacts_.start[o + 1]; ++k) {
        wc.wall.push_back(wall_contacts_.wall[k]);
        wc.history.push_back(wall_contacts_.history[k]);
        wc.touching.push_back(wall_contacts_.touching[k]);
      }
    wc.start[q + 1] = static_cast<std::uint32_t>(wc.wall.size());
  }
  bodies_ = std::move(nbs);
  spheres_ = std::move(nss);
  wall_contacts_ = std::move(wc);
  list_.renumber(new_of_old_sphere);  // drops the removed spheres' pairs; forces a rebuild
  return removed;
}

void Simulation::rebuild_neighbors() {
  list_.build(spheres_);
  update_wall_candidates();
  blocks_for_ = {};  // re-balance the threads' blocks for the new list
}

void Simulation::update_wall_candidates() {
  const std::size_t n = spheres_.size(), nw = walls_.size();
  const auto& at = list_.built_at();
  const WallContacts& old = wall_contacts_;
  const bool have_old = old.start.size() == n + 1;
  // Walls enlarged by the reach (radius + skin), so that a sphere sliding over a disc rim or a
  // cylinder end before the next build is still a candidate.
  auto candidate = [&](std::size_t i, std::size_t w) {
    if (walls_[w].translates()) return true;  // a moving wall may come to any sphere
    const double reach = spheres_.radius_m[i] + skin_m_;
    walls::WallGeometry g = walls_[w].geometry;
    if (g.kind == walls::Kind::Disc) g.radius_m += reach;
    if (g.kind == walls::Kind::Rectangle) {
      g.half_u_m += reach;
      g.half_v_m += reach;
    }
    if (g.kind == walls::Kind::Cylinder && g.length_m > 0.0) {
      g.point_m -= reach * g.normal;
      g.length_m += 2.0 * reach;
    }
    return walls::wall_hit(g, at[i], reach).touching;
  };
  auto old_slot = [&](std::size_t i, std::size_t w) -> std::int64_t {
    if (!have_old) return -1;
    for (std::uint32_t k = old.start[i]; k < old.start[i + 1]; ++k)
      if (old.wall[k] == w) return k;
    return -1;
  };
  // Pass 1: count the candidates of each sphere; pass 2: fill them, carrying the history over.
  std::vector<std::uint32_t> count(n + 1, 0);
#pragma omp parallel for proc_bind(close) schedule(static) if (n >= kParallelThreshold)
  for (std::size_t i = 0; i < n; ++i) {
    std::uint32_t c = 0;
    for (std::size_t w = 0; w < nw; ++w) {
      const std::int64_t k = old_slot(i, w);
      if (candidate(i, w) || (k >= 0 && old.touching[k])) ++c;
    }
    count[i + 1] = c;
  }
  WallContacts wc;
  wc.start.assign(n + 1, 0);
  for (std::size_t i = 0; i < n; ++i) wc.start[i + 1] = wc.start[i] + count[i + 1];
  wc.wall.resize(wc.start[n]);
  wc.history.assign(wc.start[n], {});
  wc.touching.assign(wc.start[n], 0);
#pragma omp parallel for proc_bind(close) schedule(static) if (n >= kParallelThreshold)
  for (std::size_t i = 0; i < n; ++i) {
    std::uint32_t q = wc.start[i];
    for (std::size_t w = 0; w < nw; ++w) {
      const std::int64_t k = old_slot(i, w);
      if (!(candidate(i, w) || (k >= 0 && old.touching[k]))) continue;
      wc.wall[q] = static_cast<std::uint32_t>(w);
      if (k >= 0) {
        wc.history[q] = old.history[k];
        wc.touching[q] = old.touching[k];
      }
      ++q;
    }
  }
  wall_contacts_ = std::move(wc);
}

void Simulation::refresh() {
  if (skin_m_ < 0.0) {
    double rmin = 1e300;
    for (double r : spheres_.radius_m) rmin = std::min(rmin, r);
    skin_m_ = spheres_.size() ? 0.5 * rmin : 1e-3;  // a quarter of the smallest diameter (case_file::resolved_skin_m)
  }
  list_.configure(domain_, skin_m_);
  update_wall_motion(time_s_);
  update_spheres_from_bodies();
  rebuild_neighbors();
  list_valid_ = true;
  // Forces for the first half kick; this is not a time step, so the contact history (tangential
  // and rolling springs) must not advance: it is restored after the evaluation.
  const auto pair_history = list_.history;
  const auto wall_history = wall_contacts_.history;
  forces_and_kick(false);
  for (std::size_t k = 0; k < pair_history.size(); ++k)
    if (list_.touching[k]) list_.history[k] = pair_history[k];
  for (std::size_t k = 0; k < wall_history.size(); ++k)
    if (wall_contacts_.touching[k]) wall_contacts_.history[k] = wall_history[k];
  forces_valid_ = true;
}

void Simulation::restore_after_checkpoint(double time_s, std::uint64_t steps, bool rotating, double skin_m,
                                          std::vector<Vec3> list_built_at, std::size_t list_builds) {
  time_s_ = time_s;
  steps_ = steps;
  drum_rotating_ = rotating;
  apply_drum_rotation();
  skin_m_ = skin_m;
  list_.configure(domain_, skin_m_);
  list_.restore_bookkeeping(std::move(list_built_at), list_builds);
  update_wall_motion(time_s_);  // the wall contact table itself comes from the checkpoint
  list_valid_ = true;
  forces_valid_ = true;
}

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
}  // namespace

void Simulation::step() {
  if (!forces_valid_ || !list_valid_) refresh();
  const Clock::time_point t0 = profile_on_ ? Clock::now() : Clock::time_point{};
  update_wall_motion(time_s_ + dt_s_);
  // Common case, one parallel region: drift, and unless the list must be rebuilt, the forces
  // and the second kick too. A rebuild (or a sink, which needs the drifted bodies serially)
  // leaves the region after the drift; the rest of the step then runs as separate passes.
  const bool fused = sinks_.empty();
  const bool done = fused ? step_in_one_region() : false;
  if (!done) {
    const bool moved = fused ? true : kick_drift_place();  // (fused: drifted, and a rebuild is due)
    const Clock::time_point t1 = profile_on_ ? Clock::now() : Clock::time_point{};
    if (profile_on_ && !fused) profile_.drift_s += std::chrono::duration<double>(t1 - t0).count();
    apply_sinks();
    if (moved || list_.built_at().size() != spheres_.size()) {
      check_lost_bodies();  // throws, or removes the lost bodies, before they enter the cell grid
      if (sort_every_builds_ && list_.builds() % sort_every_builds_ == 0) reorder_spatially();
      rebuild_neighbors();
      if (profile_on_) ++profile_.builds;
    }
    if (profile_on_) profile_.list_s += seconds_since(t1);
    forces_and_kick(true);
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
  // First half kick, drift, the body's spheres placed, and the list displacement test.
  const double h = 0.5 * dt_s_, dt = dt_s_;
  const std::vector<Vec3>& built = list_.built_at();
  int moved = 0;
  for (std::size_t b = b0; b < b1; ++b) {
    integrate::kick_and_drift(bodies_.position_m[b], bodies_.velocity_m_s[b], bodies_.angular_velocity_rad_s[b],
                              bodies_.angular_momentum_kg_m2_s[b], bodies_.orientation[b], bodies_.mass_kg[b],
                              bodies_.inertia_kg_m2[b], bodies_.sphere_count[b], bodies_.force_n[b],
                              bodies_.torque_n_m[b], h, dt);
    place_spheres_of(b);
    if (have_built) {
      const std::uint32_t s0 = bodies_.first_sphere[b], s1 = s0 + bodies_.sphere_count[b];
      for (std::uint32_t s = s0; s < s1; ++s)
        if (!(norm2(spheres_.position_m[s] - built[s]) <= limit2)) moved = 1;  // NaN also triggers a (failing) build
    }
  }
  return moved;
}

bool Simulation::kick_drift_place() {
  // The drift as its own pass (scenes with sinks). Each thread takes the same block of bodies
  // as in the force pass, so the data it writes stay in its own cache from step to step.
  ensure_work_blocks();
  const int blocks = static_cast<int>(block_body_.size()) - 1;
  const bool have_built = list_.built_at().size() == spheres_.size();
  const double limit2 = list_.rebuild_limit2();
  std::vector<int> moved_by(static_cast<std::size_t>(std::max(blocks, 1)), 0);
  ChunkCursors drift_chunks(threads_, blocks);
  team().run(threads_, [&](int me, int team_size) {
    drift_chunks.for_each(me, team_size, [&](int k) {
      moved_by[k] |= drift_bodies(block_body_[k], block_body_[k + 1], have_built, limit2);
    });
  });
  int moved = have_built ? 0 : 1;
  for (int m : moved_by) moved |= m;
  spheres_stale_ = false;
  return moved != 0;
}

bool Simulation::step_in_one_region() {
  if (cohesion_) return rolling_ ? step_job<true, true>(true, true) : step_job<true, false>(true, true);
  return rolling_ ? step_job<false, true>(true, true) : step_job<false, false>(true, true);
}

template <bool Cohesion, bool Rolling>
bool Simulation::step_job(bool drift, bool kick) {
  // One job of the thread team. With drift: the drift of every chunk, a barrier, and every
  // thread reads all chunks' displacement flags (so all take the same branch); if a rebuild is
  // due the job ends there (returns false: the bodies have drifted). Then: pair rows, a barrier,
  // gather, walls, body sums and (with kick) the second half kick.
  ensure_work_blocks();
  const int blocks = static_cast<int>(block_body_.size()) - 1;
  const bool have_built = list_.built_at().size() == spheres_.size();
  const double limit2 = list_.rebuild_limit2();
  if (drift) block_moved_.assign(static_cast<std::size_t>(blocks), 0);
  bool rebuild = false;
  const Clock::time_point t0 = profile_on_ ? Clock::now() : Clock::time_point{};
  double drift_end_s = 0.0, pair_end_s = 0.0;
  std::vector<PerThread> per(static_cast<std::size_t>(std::max(threads_, 1)));
  ChunkCursors drift_chunks(threads_, blocks), pair_chunks(threads_, blocks), gather_chunks(threads_, blocks);
  const PairPassData pass = pair_pass_data();
  team().run(threads_, [&](int me, int team_size) {
    if (drift) {
      drift_chunks.for_each(me, team_size, [&](int k) {
        block_moved_[k] = static_cast<std::uint8_t>(drift_bodies(block_body_[k], block_body_[k + 1], have_built, limit2));
      });
      team().barrier();
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
      const std::size_t b0 = block_body_[k], b1 = block_body_[k + 1];
      if (b0 == b1) return;
      per[me].walls += gather_and_walls<Cohesion, Rolling>(bodies_.first_sphere[b0],
                                                           bodies_.first_sphere[b1 - 1] + bodies_.sphere_count[b1 - 1]);
      reduce_and_kick(b0, b1, kick);
    });
  });
  if (drift) {
    spheres_stale_ = false;
    if (profile_on_) profile_.drift_s += drift_end_s;
    if (rebuild) return false;
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
  PairPassData d;
  d.position_m = spheres_.position_m.data();
  d.velocity_m_s = spheres_.velocity_m_s.data();
  d.angular_velocity_rad_s = spheres_.angular_velocity_rad_s.data();
  d.radius_m = spheres_.radius_m.data();
  d.body_mass_kg = spheres_.body_mass_kg.data();
  d.material = spheres_.material.data();
  d.pairs = &pairs_;
  d.list = &list_;
  d.force_n = spheres_.force_n.data();
  d.torque_n_m = spheres_.torque_n_m.data();
  d.dt_s = dt_s_;
  d.periodic = domain_.any_periodic();
  return d;
}

void Simulation::forces_and_kick(bool kick) {
  if (cohesion_) rolling_ ? step_job<true, true>(false, kick) : step_job<true, false>(false, kick);
  else rolling_ ? step_job<false, true>(false, kick) : step_job<false, false>(false, kick);
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
  for (std::size_t i = i0; i < i1; ++i) {
    Vec3 f = spheres_.force_n[i], t = spheres_.torque_n_m[i];
    for (std::uint32_t q = L.rev_start[i]; q < L.rev_start[i + 1]; ++q) {
      const std::uint32_t k = L.rev_entry[q];
      f -= L.force_i[k];
      t += L.torque_j[k];
    }
    for (std::uint32_t slot = wc.start[i]; slot < wc.start[i + 1]; ++slot) {
      const WallSpec& ws = walls_[wc.wall[slot]];
      const double ri = s.radius_m[i];
      const walls::WallHit hit = walls::wall_hit(ws.geometry, s.position_m[i], ri);
      if (!hit.touching) {
        if (wc.touching[slot]) {
          wc.touching[slot] = 0;
          wc.history[slot] = {};
        }
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

double Simulation::kinetic_energy_j() const {
  // Serial on purpose: an OpenMP reduction combines partial sums in thread-arrival order, and
  // this value decides when a settle phase ends, which must be reproducible.
  double e = 0.0;
  const std::size_t nb = bodies_.size();
  for (std::size_t b = 0; b < nb; ++b) {
    const Vec3 wb = rotate_inverse(bodies_.orientation[b], bodies_.angular_velocity_rad_s[b]);
    const Vec3 in = bodies_.inertia_kg_m2[b];
    e += 0.5 * bodies_.mass_kg[b] * norm2(bodies_.velocity_m_s[b]) +
         0.5 * (in.x * wb.x * wb.x + in.y * wb.y * wb.y + in.z * wb.z * wb.z);
  }
  return e;
}

double Simulation::translational_kinetic_energy_j() const {
  double e = 0.0;
  for (std::size_t b = 0; b < bodies_.size(); ++b) e += 0.5 * bodies_.mass_kg[b] * norm2(bodies_.velocity_m_s[b]);
  return e;
}

double Simulation::elastic_energy_j() const {
  double e = 0.0;
  const auto& s = spheres_;
  const auto& L = list_;
  const Vec3 len = domain_.length_m();
  (void)len;
  for (std::size_t i = 0; i < s.size(); ++i) {
    for (std::uint32_t k = L.row_start[i]; k < L.row_start[i + 1]; ++k) {
      const std::uint32_t j = L.j[k];
      Vec3 d = s.position_m[i] - s.position_m[j];
      if (domain_.any_periodic()) d -= L.shift(k);
      const double dist = norm(d), delta = s.radius_m[i] + s.radius_m[j] - dist;
      if (delta <= 0.0) continue;
      const auto& p = pairs_(s.material[i], s.material[j]);
      const double r_eff = s.radius_m[i] * s.radius_m[j] / (s.radius_m[i] + s.radius_m[j]);
      e += contact::hertz_elastic_energy(p.y_eff_pa, r_eff, delta);
    }
    for (const auto& w : walls_) {
      const auto hit = walls::wall_hit(w.geometry, s.position_m[i], s.radius_m[i]);
      if (!hit.touching) continue;
      const auto& p = pairs_(s.material[i], w.material);
      e += contact::hertz_elastic_energy(p.y_eff_pa, s.radius_m[i], s.radius_m[i] - hit.gap_m);
    }
  }
  return e;
}

Vec3 Simulation::linear_momentum() const {
  Vec3 p;
  for (std::size_t b = 0; b < bodies_.size(); ++b) p += bodies_.mass_kg[b] * bodies_.velocity_m_s[b];
  return p;
}

Vec3 Simulation::angular_momentum_about_origin() const {
  Vec3 l;
  for (std::size_t b = 0; b < bodies_.size(); ++b)
    l += cross(bodies_.position_m[b], bodies_.mass_kg[b] * bodies_.velocity_m_s[b]) +
         integrate::angular_momentum_from_velocity(bodies_.orientation[b], bodies_.angular_velocity_rad_s[b],
                                                   bodies_.inertia_kg_m2[b]);
  return l;
}

Vec3 Simulation::center_of_mass_m() const {
  Vec3 c;
  double m = 0.0;
  for (std::size_t b = 0; b < bodies_.size(); ++b) {
    c += bodies_.mass_kg[b] * bodies_.position_m[b];
    m += bodies_.mass_kg[b];
  }
  return m > 0.0 ? c / m : c;
}

double Simulation::total_mass_kg() const {
  double m = 0.0;
  for (double x : bodies_.mass_kg) m += x;
  return m;
}

}  // namespace biodem::sim
