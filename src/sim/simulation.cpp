// Simulation: construction, bodies and walls, sphere placement, set-up and checkpoint restore,
// and the diagnostics (energies, momenta). The time step is in simulation_step.cpp, the neighbour
// list and the bookkeeping around it (sorting, sinks, lost bodies, wall candidates) in
// simulation_list.cpp, the sphere-sphere contacts in pair_pass.cpp.
#include "sim/simulation.hpp"

#include "neighbor/candidate_scan.hpp"

#include <algorithm>
#include <cmath>

#include <omp.h>

#include "core/error.hpp"
#include "core/parallel.hpp"
#include "core/spin_team.hpp"
#include "integrate/rigid_rotation.hpp"
#include "neighbor/skin.hpp"

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
  (void)neighbor::best_candidate_scan();  // a bad BIODEM_LIST_SCAN stops here, before any step
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
    walls::place_translating_wall(w.geometry, translation_of_wall(k), t);
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
  // A stable id not given before: the bodies added so far are the ones here and the ones removed
  // (a checkpoint carries both counts, so a resumed run numbers its later insertions the same).
  bodies_.id.push_back(static_cast<std::uint32_t>(b + removed_bodies_));
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
  constexpr std::size_t kChunk = 256;
  for_each_index(nb >= kParallelThreshold ? omp_get_max_threads() : 1, (nb + kChunk - 1) / kChunk, [&](std::size_t c) {
    for (std::size_t b = c * kChunk; b < std::min(nb, (c + 1) * kChunk); ++b) place_spheres_of(b);
  });
}

void Simulation::refresh() {
  if (skin_m_ < 0.0) {
    double rmin = 1e300;
    for (double r : spheres_.radius_m) rmin = std::min(rmin, r);
    skin_m_ = spheres_.size() ? neighbor::default_skin_m(rmin) : 1e-3;  // as case_file::resolved_skin_m
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

double Simulation::kinetic_energy_j() const {
  require_not_ahead();
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
  require_not_ahead();
  double e = 0.0;
  for (std::size_t b = 0; b < bodies_.size(); ++b) e += 0.5 * bodies_.mass_kg[b] * norm2(bodies_.velocity_m_s[b]);
  return e;
}

double Simulation::elastic_energy_j() const {
  require_not_ahead();
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
  require_not_ahead();
  Vec3 p;
  for (std::size_t b = 0; b < bodies_.size(); ++b) p += bodies_.mass_kg[b] * bodies_.velocity_m_s[b];
  return p;
}

Vec3 Simulation::angular_momentum_about_origin() const {
  require_not_ahead();
  Vec3 l;
  for (std::size_t b = 0; b < bodies_.size(); ++b)
    l += cross(bodies_.position_m[b], bodies_.mass_kg[b] * bodies_.velocity_m_s[b]) +
         integrate::angular_momentum_from_velocity(bodies_.orientation[b], bodies_.angular_velocity_rad_s[b],
                                                   bodies_.inertia_kg_m2[b]);
  return l;
}

Vec3 Simulation::center_of_mass_m() const {
  require_not_ahead();
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
