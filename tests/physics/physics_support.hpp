// Helpers for the physics verification tests: build a Simulation with one particle material
// (index 0) and one wall material (index 1), with the pair parameters computed here from E, nu
// and e exactly as SPEC 2.1-2.2 state them (independently of the engine's own helpers, so the
// tests check the engine against the SPEC and not against itself):
//     1/Y* = (1 - nu_i^2)/Y_i + (1 - nu_j^2)/Y_j
//     1/G* = 2 (2 - nu_i)(1 + nu_i)/Y_i + 2 (2 - nu_j)(1 + nu_j)/Y_j
//     beta = ln(e) / sqrt(ln^2(e) + pi^2)
// For a sphere-wall pair the wall's own E and nu enter (R_j, m_j -> infinity).
// Also the closed-form Hertz results the tests compare with (Johnson, Contact Mechanics, 1985).
#pragma once
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numbers>
#include <vector>

#include <omp.h>

#include "config/case_config.hpp"
#include "contact/pair_table.hpp"
#include "shapes/clump_template.hpp"
#include "sim/simulation.hpp"
#include "walls/wall_geometry.hpp"

namespace biodem::phys {

constexpr std::uint16_t kParticle = 0;  // material index of the particles
constexpr std::uint16_t kWall = 1;      // material index of every wall

struct Material {
  double young_pa = 0.0;
  double poisson = 0.0;
  double density_kg_m3 = 0.0;  // particles only
};

/// Contact properties of a pair of materials (SPEC 2.1: per pair, not per material).
struct Interaction {
  double restitution = 1.0;
  double friction = 0.0;
  double rolling_friction = 0.0;
  double cohesion_energy_density_j_m3 = 0.0;
};

inline double effective_young_pa(const Material& a, const Material& b) {
  return 1.0 / ((1.0 - a.poisson * a.poisson) / a.young_pa + (1.0 - b.poisson * b.poisson) / b.young_pa);
}
inline double effective_shear_pa(const Material& a, const Material& b) {
  return 1.0 / (2.0 * (2.0 - a.poisson) * (1.0 + a.poisson) / a.young_pa +
                2.0 * (2.0 - b.poisson) * (1.0 + b.poisson) / b.young_pa);
}
inline double beta_from_restitution(double e) {
  const double l = std::log(e);  // e = 1 -> beta = 0 (no damping)
  return l / std::sqrt(l * l + std::numbers::pi * std::numbers::pi);
}

inline contact::PairParams pair_params(const Material& a, const Material& b, const Interaction& c) {
  contact::PairParams p;
  p.y_eff_pa = effective_young_pa(a, b);
  p.g_eff_pa = effective_shear_pa(a, b);
  p.beta = beta_from_restitution(c.restitution);
  p.friction = c.friction;
  p.rolling_friction = c.rolling_friction;
  p.cohesion_energy_density_j_m3 = c.cohesion_energy_density_j_m3;
  p.defined = true;
  return p;
}

inline double sphere_volume_m3(double r) { return 4.0 / 3.0 * std::numbers::pi * r * r * r; }
inline double sphere_mass_kg(double r, double rho) { return rho * sphere_volume_m3(r); }

inline shapes::ClumpTemplate sphere_template(double radius_m) {
  config::Shape s;
  s.name = "sphere";
  s.kind = config::ShapeKind::Sphere;
  s.diameter_m = 2.0 * radius_m;
  return shapes::make_template(s, 1.0);
}

/// Needle clump of SPEC 3 (d50, aspect ratio a50, overlap factor c), lengths times `coarse_grain`.
inline shapes::ClumpTemplate needle_template(double d50_m, double aspect_ratio, double overlap_factor,
                                             double coarse_grain) {
  config::Shape s;
  s.name = "needle";
  s.kind = config::ShapeKind::Needle;
  s.d50_m = d50_m;
  s.aspect_ratio = aspect_ratio;
  s.overlap_factor = overlap_factor;
  return shapes::make_template(s, coarse_grain);
}

/// General clump template from sphere centres and radii (any frame: the engine recentres it).
inline shapes::ClumpTemplate clump_template(const std::vector<Vec3>& centres_m, const std::vector<double>& radii_m) {
  config::Shape s;
  s.name = "clump";
  s.kind = config::ShapeKind::Clump;
  for (std::size_t i = 0; i < centres_m.size(); ++i)
    s.spheres.push_back({{centres_m[i].x, centres_m[i].y, centres_m[i].z}, radii_m[i]});
  return shapes::make_template(s, 1.0);
}

/// Everything needed to build a Simulation with one particle and one wall material.
struct SimSetup {
  Material particle;
  Material wall;
  Interaction particle_particle;
  Interaction particle_wall;
  std::vector<shapes::ClumpTemplate> templates;
  double dt_s = 1e-6;
  Vec3 gravity_m_s2;
  bool tangential_reduce = false;  // [contact] tangential_reduce for both pairs
};

inline contact::PairTable pair_table(const SimSetup& s) {
  contact::PairTable t(2);
  auto pp = pair_params(s.particle, s.particle, s.particle_particle);
  auto pw = pair_params(s.particle, s.wall, s.particle_wall);
  pp.tangential_reduce = pw.tangential_reduce = s.tangential_reduce;
  t.set(kParticle, kParticle, pp);
  t.set(kParticle, kWall, pw);
  return t;
}

inline sim::Simulation make_simulation(const SimSetup& s) {
  return sim::Simulation(s.templates, {s.particle.density_kg_m3, 0.0}, pair_table(s), s.dt_s, s.gravity_m_s2);
}

inline std::uint32_t add_particle(sim::Simulation& sim, std::uint32_t shape, const Vec3& x, const Vec3& v = {},
                                  const Vec3& w = {}, const Quat& q = {}) {
  sim::BodyInit b;
  b.shape = shape;
  b.material = kParticle;
  b.position_m = x;
  b.velocity_m_s = v;
  b.angular_velocity_rad_s = w;
  b.orientation = q;
  return sim.add_body(b);
}

inline sim::WallSpec plane_wall(const Vec3& point, const Vec3& normal) {
  sim::WallSpec w;
  w.geometry.kind = walls::Kind::Plane;
  w.geometry.point_m = point;
  w.geometry.normal = normalized(normal);
  w.material = kWall;
  return w;
}

/// Inside of an infinite cylinder turning at omega about its axis (right-hand rule).
inline sim::WallSpec cylinder_wall(const Vec3& axis_point, const Vec3& axis, double radius_m, double omega_rad_s) {
  sim::WallSpec w;
  w.geometry.kind = walls::Kind::Cylinder;
  w.geometry.point_m = axis_point;
  w.geometry.normal = normalized(axis);
  w.geometry.radius_m = radius_m;
  w.geometry.length_m = 0.0;
  w.geometry.angular_velocity_rad_s = omega_rad_s;
  w.material = kWall;
  return w;
}

// --- Hertz theory (elastic impact at relative normal speed v; static load F) ---
inline double hertz_contact_time_s(double m_eff, double r_eff, double y_eff, double v) {
  return 2.868 * std::pow(m_eff * m_eff / (r_eff * y_eff * y_eff * v), 0.2);
}
inline double hertz_max_overlap_m(double m_eff, double r_eff, double y_eff, double v) {
  return std::pow(15.0 * m_eff * v * v / (16.0 * y_eff * std::sqrt(r_eff)), 0.4);
}
inline double hertz_peak_force_n(double m_eff, double r_eff, double y_eff, double v) {
  return 4.0 / 3.0 * y_eff * std::sqrt(r_eff) * std::pow(hertz_max_overlap_m(m_eff, r_eff, y_eff, v), 1.5);
}
/// Overlap under a static normal load F: F = (4/3) Y* sqrt(R*) delta^(3/2).
inline double hertz_static_overlap_m(double load_n, double r_eff, double y_eff) {
  return std::pow(3.0 * load_n / (4.0 * y_eff * std::sqrt(r_eff)), 2.0 / 3.0);
}

/// Runs a scope with a fixed OpenMP thread count and restores the previous one. The one- and
/// two-sphere tests run on one thread: the physics is the same code path for any thread count
/// (the engine is bit-identical across thread counts, see test_determinism.cpp), and on a
/// loaded machine the per-step parallel regions of a one-sphere system cost far more than its
/// physics (measured: 54 ms on one thread vs 0.9-47 s on two busy cores for the same test).
class ScopedThreads {
 public:
  explicit ScopedThreads(int n) : previous_(omp_get_max_threads()) { omp_set_num_threads(n); }
  ~ScopedThreads() { omp_set_num_threads(previous_); }
  ScopedThreads(const ScopedThreads&) = delete;
  ScopedThreads& operator=(const ScopedThreads&) = delete;

 private:
  int previous_;
};

/// One line per measured quantity, collected from the test log for the verification report.
inline void report(const char* what, double measured, double expected) {
  std::printf("[measured] %s: %.6g (expected %.6g, rel. dev. %+.3e)\n", what, measured, expected,
              expected != 0.0 ? measured / expected - 1.0 : measured - expected);
  std::fflush(stdout);
}

/// Least-squares slope of y(t) (accelerations and decelerations from sampled velocities).
inline double fit_slope(const std::vector<double>& t, const std::vector<double>& y) {
  double st = 0, sy = 0, stt = 0, sty = 0;
  const double n = static_cast<double>(t.size());
  for (std::size_t i = 0; i < t.size(); ++i) {
    st += t[i];
    sy += y[i];
    stt += t[i] * t[i];
    sty += t[i] * y[i];
  }
  return (n * sty - st * sy) / (n * stt - st * st);
}

}  // namespace biodem::phys
