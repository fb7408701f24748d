// A raw-biomass needle dropped onto a plane comes to rest lying flat (issue "Cohesive elongated
// particles", verification item 3; SPEC 2: "for a clump the sums run over all its spheres'
// contacts; torques about the clump's centre of mass").
//
// Needle: SPEC 8 raw biomass, d50 = 746 um coarse-grained x4 (sphere diameter 2.984 mm),
// a50 = 0.38, c = 0.2 -> three spheres, clump length 7.76 mm; rho = 350 kg/m^3, E = 5e6 Pa,
// nu = 0.3; particle-wall pair: e = 0.1, mu_s = 0.4, mu_r = 0.5, no cohesion (SPEC 8's
// particle-steel row without CED); the wall uses the particle's E and nu, as the reference cases
// do; dt = 1e-5 s (the raw-biomass time step).
//
// Statics of the rest state: a straight needle on a plane has three unknown normal forces and
// three equations (vertical force, two tilting moments). Lying flat, by symmetry the end spheres
// carry equal loads; without rolling torques all three overlaps are equal and each sphere
// carries W/3. At rest the vertical contact forces must add up to the weight W = m g whatever
// their distribution (Newton for the body with zero acceleration).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <string>

#include "physics_support.hpp"

using namespace biodem;
using namespace biodem::phys;

namespace {

const Material kBiomass{5e6, 0.3, 350.0};
constexpr double kG = 9.81;

struct DropResult {
  double tilt_deg = 0.0;        // angle of the long axis to the horizontal at rest
  double force_sum_n = 0.0;     // sum of the spheres' vertical contact forces at rest
  double weight_n = 0.0;
  double max_sphere_z_minus_r = 0.0;  // < 0: every sphere overlaps the plane
  double speed_m_s = 0.0, spin_rad_s = 0.0;
  double max_load_share_dev = 0.0;    // max |F_z,s / (W/3) - 1| over the three spheres
  double height_m = 0.0;              // centre-of-mass height at rest
  double hertz_height_m = 0.0;        // R - delta(W/3): all three spheres equally loaded
  double initial_tilt_deg = 0.0;
};

DropResult drop(std::uint64_t seed) {
  const ScopedThreads one_thread(1);
  std::mt19937_64 gen(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  SimSetup su;
  su.particle = kBiomass;
  su.wall = kBiomass;
  su.particle_wall = {0.1, 0.4, 0.5, 0.0};
  su.particle_particle = su.particle_wall;
  su.templates = {needle_template(746e-6, 0.38, 0.2, 4.0)};
  su.dt_s = 1e-5;
  su.gravity_m_s2 = {0, 0, -kG};
  sim::Simulation s = make_simulation(su);
  s.add_wall(plane_wall({0, 0, 0}, {0, 0, 1}));
  const auto& t = su.templates[0];
  const double r = t.radii_m[0];

  // Random orientation: yaw about z, then a tilt of 10-40 degrees of the long axis (body x)
  // about a horizontal axis; small random spin. Lowest sphere 1 mm above the plane.
  DropResult res;
  const double yaw = 2 * std::numbers::pi * u01(gen);
  res.initial_tilt_deg = 10.0 + 30.0 * u01(gen);
  const Quat q = axis_angle({0, 0, 1}, yaw) * axis_angle({0, 1, 0}, res.initial_tilt_deg * std::numbers::pi / 180.0) *
                 axis_angle({1, 0, 0}, 2 * std::numbers::pi * u01(gen));
  double lowest = 1e300;
  for (const auto& o : t.offsets_m) lowest = std::min(lowest, rotate(q, o).z - r);
  const Vec3 w{20.0 * (u01(gen) - 0.5), 20.0 * (u01(gen) - 0.5), 20.0 * (u01(gen) - 0.5)};
  add_particle(s, 0, {0, 0, 1e-3 - lowest}, {}, w, q);

  s.run_steps(60000);  // 0.6 s: fall from 1 mm (14 ms), impact at 0.14 m/s and settling (e = 0.1)

  const double m = s.bodies().mass_kg[0];
  res.weight_n = m * kG;
  const Vec3 axis = rotate(s.bodies().orientation[0], Vec3{1, 0, 0});
  res.tilt_deg = std::asin(std::min(1.0, std::abs(axis.z))) * 180.0 / std::numbers::pi;
  res.max_sphere_z_minus_r = -1e300;
  for (std::size_t k = 0; k < s.spheres().size(); ++k) {
    res.force_sum_n += s.spheres().force_n[k].z;
    res.max_sphere_z_minus_r = std::max(res.max_sphere_z_minus_r, s.spheres().position_m[k].z - r);
    res.max_load_share_dev =
        std::max(res.max_load_share_dev, std::abs(s.spheres().force_n[k].z / (res.weight_n / 3.0) - 1.0));
  }
  res.speed_m_s = norm(s.bodies().velocity_m_s[0]);
  res.spin_rad_s = norm(s.bodies().angular_velocity_rad_s[0]);
  res.height_m = s.bodies().position_m[0].z;
  res.hertz_height_m = r - hertz_static_overlap_m(res.weight_n / 3.0, r, effective_young_pa(kBiomass, kBiomass));
  return res;
}

}  // namespace

// Three drops with different random tilts, yaws and spins. Tolerances:
//  - every sphere touches the plane (z_s < R);
//  - long axis horizontal within 0.05 degrees: lying flat on equal Hertz overlaps the tilt is
//    zero; locked-in rolling and tangential springs can shift load between the end spheres, but
//    the overlaps are ~0.5 um over a 4.8 mm end-to-end distance, so any such tilt is < 1e-4 rad;
//  - the vertical contact forces add up to the weight within 0.5 % (the brief's);
//  - at rest: speed < 1e-4 m/s and spin < 0.05 rad/s (after an impact at ~0.14 m/s and the
//    given spin of up to 17 rad/s). EPSD2 has no rolling dashpot, so an elastic rocking mode of
//    the rolling springs may survive with an amplitude below the plastic limit; it is tiny.
// Reported, not asserted: each sphere's share of the load against W/3 (measured: 10-27 % off;
// the rolling springs lock in torques of up to mu_r R F_n per sphere, enough to move up to ~W/3
// between the end spheres, so the split is history-dependent while the sum is not), and the
// centre-of-mass height against R - delta(W/3) (measured within 2e-6).
TEST(NeedleOnPlane, ComesToRestLyingFlatCarryingItsWeight) {
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    const DropResult r = drop(seed);
    const std::string tag = "needle drop seed " + std::to_string(seed);
    std::printf("[measured] %s: initial tilt %.2f deg\n", tag.c_str(), r.initial_tilt_deg);
    report((tag + ": tilt of the long axis at rest [deg]").c_str(), r.tilt_deg, 0.0);
    report((tag + ": sum of vertical contact forces [N]").c_str(), r.force_sum_n, r.weight_n);
    report((tag + ": max over spheres of z - R [m]").c_str(), r.max_sphere_z_minus_r, 0.0);
    report((tag + ": speed at rest [m/s]").c_str(), r.speed_m_s, 0.0);
    report((tag + ": spin at rest [rad/s]").c_str(), r.spin_rad_s, 0.0);
    report((tag + ": max |F_z,sphere / (W/3) - 1|").c_str(), r.max_load_share_dev, 0.0);
    report((tag + ": centre-of-mass height [m]").c_str(), r.height_m, r.hertz_height_m);
    EXPECT_LT(r.max_sphere_z_minus_r, 0.0) << tag;
    EXPECT_LT(r.tilt_deg, 0.05) << tag;
    EXPECT_NEAR(r.force_sum_n / r.weight_n, 1.0, 5e-3) << tag;
    EXPECT_LT(r.speed_m_s, 1e-4) << tag;
    EXPECT_LT(r.spin_rad_s, 0.05) << tag;
  }
}
