// A sphere inside a rotating cylinder (SPEC 2.2: for walls, v_rel includes the wall's own
// velocity at the contact point; SPEC 5: the drum mantle turns). Cylinder axis +z through the
// origin, inner radius 50 mm, turning counter-clockwise (omega = +2 rad/s about +z, surface
// speed V = 0.1 m/s); sphere R = 5 mm at the bottom, gravity -y, mu = 1, e = 0.5.
//
// Theory (rigid sphere, no rolling resistance): the wall drags the bottom of the sphere towards
// +x (the rising side) and the sphere slips until its contact point moves with the wall; the
// friction impulse then is (2/7) m V (slip rate (7/2) F/m), so the centre starts at
// u0 = (2/7) V. From then on it rolls without slip and, whatever V is, swings like a pendulum
// with omega_p = sqrt(5 g / (7 (R_c - R))) about the bottom: x(t) ~ (u0/omega_p) sin(omega_p t).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "physics_support.hpp"

using namespace biodem;
using namespace biodem::phys;

namespace {

constexpr double kRc = 50e-3, kR = 5e-3, kG = 9.81, kOmega = 2.0;
const Material kPolymer{1e8, 0.3, 2500.0};

SimSetup cylinder_setup() {
  SimSetup su;
  su.particle = kPolymer;
  su.wall = kPolymer;
  su.particle_wall = {0.5, 1.0, 0.0, 0.0};
  su.particle_particle = su.particle_wall;
  su.templates = {sphere_template(kR)};
  su.dt_s = 2e-5;  // ~65 steps per period of the tangential contact spring (~1.3 ms)
  su.gravity_m_s2 = {0, -kG, 0};
  return su;
}

/// Sphere at the bottom, at the static Hertz overlap (R* = R: the wall curvature is not used).
void add_bottom_sphere(sim::Simulation& s) {
  const double m = sphere_mass_kg(kR, kPolymer.density_kg_m3);
  const double d0 = hertz_static_overlap_m(m * kG, kR, effective_young_pa(kPolymer, kPolymer));
  add_particle(s, 0, {0, -(kRc - kR + d0), 0});
}

}  // namespace

// Tolerances: no-slip |v_contact - v_wall| < 1 % of V from 20 ms on (the slip phase lasts
// (2/7) V / (mu g) ~ 3 ms; afterwards only the elastic tangential spring creeps, at a rate
// d(F_t/k_t)/dt ~ 1e-5 V). The first excursion must be towards +x and reach the pendulum
// amplitude u0/omega_p within 3 % (small-angle approximation 0.05 rad: 0.04 %; the centre
// decelerates already during the 3 ms slip phase and the contact lever is R - delta/2: < 1 %).
TEST(RotatingCylinder, WallVelocityDragsSphereTowardsRisingSide) {
  const ScopedThreads one_thread(1);
  sim::Simulation s = make_simulation(cylinder_setup());
  s.add_wall(cylinder_wall({0, 0, 0}, {0, 0, 1}, kRc, kOmega));
  add_bottom_sphere(s);
  const double v_wall_speed = kOmega * kRc;
  const double omega_p = std::sqrt(5.0 * kG / (7.0 * (kRc - kR)));
  const double half_period = std::numbers::pi / omega_p;
  const double amplitude = 2.0 / 7.0 * v_wall_speed / omega_p;
  double worst_slip = 0.0, x_max = 0.0, x_min_after = 1e300, t_of_max = 0.0;
  const auto n_steps = static_cast<std::uint64_t>(0.9 * half_period / s.dt_s());
  for (std::uint64_t k = 0; k < n_steps; ++k) {
    s.step();
    ASSERT_EQ(s.contact_count(), 1u);
    const Vec3 x = s.bodies().position_m[0], v = s.bodies().velocity_m_s[0], w = s.bodies().angular_velocity_rad_s[0];
    if (x.x > x_max) {
      x_max = x.x;
      t_of_max = s.time_s();
    }
    if (s.time_s() < 0.02) continue;
    x_min_after = std::min(x_min_after, x.x);
    const Vec3 out = normalized(Vec3{x.x, x.y, 0.0});  // from the axis through the centre
    const Vec3 contact_point = x + kR * out;
    const Vec3 v_sphere = v + cross(w, kR * out);
    const Vec3 v_wall = cross(Vec3{0, 0, kOmega}, contact_point);
    worst_slip = std::max(worst_slip, norm(v_sphere - v_wall));
  }
  report("rotating cylinder: worst |v_contact - v_wall| / V after 20 ms", worst_slip / v_wall_speed, 0.0);
  report("rotating cylinder: first excursion x_max [m]", x_max, amplitude);
  report("rotating cylinder: time of x_max [s]", t_of_max, 0.5 * half_period);
  EXPECT_LT(worst_slip, 0.01 * v_wall_speed);
  EXPECT_GT(x_min_after, 0.0) << "the sphere must stay on the rising (+x) side during the first swing";
  EXPECT_NEAR(x_max / amplitude, 1.0, 0.03);
  EXPECT_NEAR(t_of_max / (0.5 * half_period), 1.0, 0.05);  // quarter period; +-2 % from the slip phase
}

// Rotation off (the drum-wall switch, SPEC 5): the same sphere at its static overlap does not
// move. Tolerance: displacements below 1e-12 m and speeds below 1e-9 m/s (it starts at the
// Hertz equilibrium to round-off; by symmetry nothing acts along x or z).
TEST(RotatingCylinder, NothingMovesWithRotationOff) {
  const ScopedThreads one_thread(1);
  sim::Simulation s = make_simulation(cylinder_setup());
  sim::WallSpec drum = cylinder_wall({0, 0, 0}, {0, 0, 1}, kRc, 0.0);
  drum.drum_wall = true;
  s.add_wall(drum);
  s.set_drum_angular_velocity(kOmega);
  s.set_drum_rotation(false);
  add_bottom_sphere(s);
  const Vec3 x0 = s.bodies().position_m[0];
  s.run_steps(5000);  // 0.1 s
  const Vec3 dx = s.bodies().position_m[0] - x0;
  report("rotation off: displacement [m]", norm(dx), 0.0);
  report("rotation off: speed [m/s]", norm(s.bodies().velocity_m_s[0]), 0.0);
  EXPECT_LT(norm(dx), 1e-12);
  EXPECT_LT(norm(s.bodies().velocity_m_s[0]), 1e-9);
  EXPECT_LT(norm(s.bodies().angular_velocity_rad_s[0]), 1e-9);

  // Switching the drum on makes the same wall drag the sphere towards +x.
  s.set_drum_rotation(true);
  EXPECT_EQ(s.walls()[0].geometry.angular_velocity_rad_s, kOmega);
  s.run_steps(1000);  // 20 ms
  EXPECT_GT(s.bodies().position_m[0].x, 1e-4);
  EXPECT_GT(s.bodies().velocity_m_s[0].x, 0.0);
}
