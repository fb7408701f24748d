// Simulation: the neighbour list and the bookkeeping around its rebuilds: spatial re-sorting of
// the bodies, sinks, lost bodies, removal, and the per-sphere wall candidates.
#include "sim/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <omp.h>

#include "core/error.hpp"
#include "core/parallel.hpp"
#include "core/spin_team.hpp"

namespace biodem::sim {

void Simulation::reorder_spatially() {
  const std::size_t nb = bodies_.size(), ns = spheres_.size();
  if (nb < 2) return;
  double r_max = 0.0;
  for (double r : spheres_.radius_m) r_max = std::max(r_max, r);
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const auto& x : bodies_.position_m)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], x[k]);
      hi[k] = std::max(hi[k], x[k]);
    }
  // Cells in rows along the shortest extent of the bed, rows in planes, planes along the longest
  // extent: the threads' blocks are contiguous index ranges, so they are cut by planes across the
  // longest extent, where the bed's cross-section, and with it the number of contacts between two
  // threads' spheres, is smallest. (A thin drum cut across its axis shares about half its
  // spheres between threads: their cache lines then travel between cores every step.)
  int axis[3] = {0, 1, 2};  // major, middle, minor
  std::stable_sort(axis, axis + 3, [&](int a, int b) { return hi[a] - lo[a] > hi[b] - lo[b]; });
  const double cell = 2.0 * r_max + skin_m_;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> key(nb);
  for (std::size_t b = 0; b < nb; ++b) {
    std::uint64_t c[3];
    for (int k = 0; k < 3; ++k)
      c[k] = static_cast<std::uint64_t>(std::min(2.0e6, std::floor((bodies_.position_m[b][k] - lo[k]) / cell)));
    key[b] = {(c[axis[0]] << 42) | (c[axis[1]] << 21) | c[axis[2]], static_cast<std::uint32_t>(b)};
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
  adopt_renumbered(std::move(nbs), std::move(nss), old_sphere_of_new, new_of_old_sphere);
}

void Simulation::adopt_renumbered(state::BodyStore&& nbs, state::SphereStore&& nss,
                                  const std::vector<std::uint32_t>& old_sphere_of_new,
                                  const std::vector<std::uint32_t>& new_of_old_sphere) {
  // Each kept sphere takes its wall slots (and their history) along.
  const std::size_t ns_new = old_sphere_of_new.size();
  WallContacts wc;
  wc.start.assign(ns_new + 1, 0);
  const bool have_wc = wall_contacts_.start.size() == spheres_.size() + 1;
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
  list_.renumber(new_of_old_sphere);  // a removed sphere's pairs are dropped; forces a rebuild
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

void Simulation::check_finite_bodies() const {
  for (std::size_t b = 0; b < bodies_.size(); ++b) {
    const Vec3 x = bodies_.position_m[b];
    if (std::isfinite(x.x) && std::isfinite(x.y) && std::isfinite(x.z)) continue;
    char buf[256];
    std::snprintf(buf, sizeof buf, "body %u: its position became non-finite by t = %.6g s", bodies_.id[b], time_s_);
    throw Error(std::string(buf) + ": the simulation became unstable (is [run].dt_s too large?)");
  }
}

void Simulation::check_lost_bodies() {
  if (lost_region_.kind == LostRegion::Kind::None) return;
  check_finite_bodies();  // (an unstable run, not a lost body, in either mode)
  const LostRegion& r = lost_region_;
  const std::size_t nb = bodies_.size();
  std::vector<std::uint8_t> flag(nb, 0);
  std::size_t count = 0;
  for (std::size_t b = 0; b < nb; ++b) {
    const Vec3 x = bodies_.position_m[b];
    const double rb = templates_[bodies_.shape[b]].bounding_radius_m;
    bool lost = false;  // (non-finite positions: check_finite_bodies above)
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
  state::SphereStore nss = state::gather(spheres_, old_sphere_of_new);
  for (std::size_t q = 0; q < keep_body.size(); ++q)
    for (std::uint32_t s = nbs.first_sphere[q]; s < nbs.first_sphere[q] + nbs.sphere_count[q]; ++s)
      nss.body[s] = static_cast<std::uint32_t>(q);
  adopt_renumbered(std::move(nbs), std::move(nss), old_sphere_of_new, new_of_old_sphere);
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
  // cylinder end before the next build is still a candidate (walls::within_reach, which the GPU
  // engine's wall-slot list uses too).
  auto candidate = [&](std::size_t i, std::size_t w) {
    if (walls_[w].translates()) return true;  // a moving wall may come to any sphere
    return walls::within_reach(walls_[w].geometry, at[i], spheres_.radius_m[i] + skin_m_);
  };
  auto old_slot = [&](std::size_t i, std::size_t w) -> std::int64_t {
    if (!have_old) return -1;
    for (std::uint32_t k = old.start[i]; k < old.start[i + 1]; ++k)
      if (old.wall[k] == w) return k;
    return -1;
  };
  // Pass 1: each sphere's candidate walls (a flag per sphere and wall) and their count; pass 2:
  // fill the slots, carrying the history over. Chunks of spheres on the step's thread team
  // (core/spin_team.hpp: its workers are spinning).
  constexpr std::size_t kChunk = 256;
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  const int threads = n >= kParallelThreshold ? omp_get_max_threads() : 1;
  std::vector<std::uint32_t> count(n + 1, 0);
  std::vector<std::uint8_t> is_candidate(n * nw);
  for_each_index(threads, chunks, [&](std::size_t ch) {
    for (std::size_t i = ch * kChunk; i < std::min(n, (ch + 1) * kChunk); ++i) {
      std::uint32_t c = 0;
      for (std::size_t w = 0; w < nw; ++w) {
        const std::int64_t k = old_slot(i, w);
        const bool keep = candidate(i, w) || (k >= 0 && old.touching[k]);
        is_candidate[i * nw + w] = keep ? 1 : 0;
        c += keep ? 1 : 0;
      }
      count[i + 1] = c;
    }
  });
  WallContacts wc;
  wc.start.assign(n + 1, 0);
  for (std::size_t i = 0; i < n; ++i) wc.start[i + 1] = wc.start[i] + count[i + 1];
  wc.wall.resize(wc.start[n]);
  wc.history.assign(wc.start[n], {});
  wc.touching.assign(wc.start[n], 0);
  for_each_index(threads, chunks, [&](std::size_t ch) {
    for (std::size_t i = ch * kChunk; i < std::min(n, (ch + 1) * kChunk); ++i) {
      std::uint32_t q = wc.start[i];
      for (std::size_t w = 0; w < nw; ++w) {
        if (!is_candidate[i * nw + w]) continue;
        wc.wall[q] = static_cast<std::uint32_t>(w);
        if (const std::int64_t k = old_slot(i, w); k >= 0) {
          wc.history[q] = old.history[k];
          wc.touching[q] = old.touching[k];
        }
        ++q;
      }
    }
  });

  wall_contacts_ = std::move(wc);
}
}  // namespace biodem::sim
