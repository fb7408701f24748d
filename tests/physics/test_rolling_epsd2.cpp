// EPSD2 rolling resistance (SPEC 2.3; issue "Cohesive elongated particles", verification
// item 5; SPEC 10: "rolling limit"):
//     k_r = k_t R*^2,   M_r += k_r w_t dt,   |M_r| <= mu_r R* |F_n|,   torque -M_r on the sphere
// with R* = R for a sphere on a wall and w_t the part of the relative angular velocity
// perpendicular to the contact normal. No rolling dashpot.
//
// Sphere: raw biomass x4 of SPEC 8 (R = 1.492 mm, rho = 350, E = 5e6, nu = 0.3), on a plane with
// the particle's E and nu (as the reference cases' walls); mu_r = 0.5 (the particle-wall value of
// SPEC 8), e = 0.1, no cohesion (so |F_n| is the plain Hertz load and the cohesion-friction
// artefact of SPEC 2.4 cannot enter); dt = 1e-5 s, the raw-biomass time step (~80 steps per
// period of the rolling spring, T = 2 pi sqrt(I / k_r) ~ 0.8 ms).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include "physics_support.hpp"

using namespace biodem;
using namespace biodem::phys;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kG = 9.81;
constexpr double kR = 0.5 * 4.0 * 746e-6;
constexpr double kMuR = 0.5;
const Material kBiomass{5e6, 0.3, 350.0};

/// A sphere resting on the plane z = 0 under gravity tilted by theta about y (the slope runs
/// down along +x), starting at rest at its static Hertz overlap.
sim::Simulation sphere_on_plane(double theta_rad, double mu_s, const Vec3& w0 = {}) {
  SimSetup su;
  su.particle = kBiomass;
  su.wall = kBiomass;
  su.particle_wall = {0.1, mu_s, kMuR, 0.0};
  su.particle_particle = su.particle_wall;
  su.templates = {sphere_template(kR)};
  su.dt_s = 1e-5;
  su.gravity_m_s2 = {kG * std::sin(theta_rad), 0, -kG * std::cos(theta_rad)};
  sim::Simulation s = make_simulation(su);
  s.add_wall(plane_wall({0, 0, 0}, {0, 0, 1}));
  const double load = sphere_mass_kg(kR, kBiomass.density_kg_m3) * kG * std::cos(theta_rad);
  add_particle(s, 0, {0, 0, kR - hertz_static_overlap_m(load, kR, effective_young_pa(kBiomass, kBiomass))}, {}, w0);
  return s;
}

}  // namespace

// Spin-down in place. The sphere rests on the plane (|F_n| = m g) and spins about a horizontal
// axis at w0 = 200 rad/s. With mu_s = 0 there is no tangential force (the Coulomb limit is zero),
// so the sphere does not roll: it spins in place and only EPSD2 acts. The rolling spring
// reaches its plastic limit within a microsecond, then the torque is the constant
// mu_r R m g and
//     dw/dt = -mu_r R m g / I = -2.5 mu_r g / R  (I = 2/5 m R^2)   = -8218 rad/s^2,
// so it stops after w0 / 8218 = 24 ms. Tolerance 1 % on the fitted deceleration (the brief's;
// |F_n| = m g holds to the start's round-off since nothing moves normally).
// After the stop, M_r unloads elastically: an undamped oscillation (EPSD2 has no dashpot) of
// the rolling spring that starts at the plastic limit, so
//     |w| <= M_lim / sqrt(k_r I),   the rotation stays within 2 M_lim / k_r of where it stopped,
// with k_r = k_t R^2 = 8 G* sqrt(R delta) R^2; asserted with 10 % margin (discrete stop).
TEST(Epsd2, SpinningSphereDeceleratesAtRollingLimitAndStops) {
  const ScopedThreads one_thread(1);
  const double w0 = 200.0;
  sim::Simulation s = sphere_on_plane(0.0, 0.0, {0, w0, 0});
  const double m = sphere_mass_kg(kR, kBiomass.density_kg_m3), inertia = 0.4 * m * kR * kR;
  const double decel = kMuR * kR * m * kG / inertia;
  const double delta = hertz_static_overlap_m(m * kG, kR, effective_young_pa(kBiomass, kBiomass));
  const double k_r = 8.0 * effective_shear_pa(kBiomass, kBiomass) * std::sqrt(kR * delta) * kR * kR;
  const double m_lim = kMuR * kR * m * kG;

  std::vector<double> t, w;
  double t_stop = -1.0;
  for (int k = 0; k < 3000 && t_stop < 0; ++k) {  // at most 30 ms
    s.step();
    const double wy = s.bodies().angular_velocity_rad_s[0].y;
    if (wy < 0.9 * w0 && wy > 0.1 * w0) {
      t.push_back(s.time_s());
      w.push_back(wy);
    }
    if (wy <= 0.0) t_stop = s.time_s();
  }
  ASSERT_GT(t_stop, 0.0) << "did not stop within 30 ms";
  const double rate = -fit_slope(t, w);
  report("spin-down: deceleration dw/dt [rad/s^2]", rate, decel);
  report("spin-down: stop time [s]", t_stop, w0 / decel);
  EXPECT_NEAR(rate / decel, 1.0, 0.01);

  double w_max = 0.0, angle = 0.0, angle_min = 0.0, angle_max = 0.0, drift = 0.0;
  for (int k = 0; k < 2000; ++k) {  // 20 ms after the stop
    s.step();
    const double wy = s.bodies().angular_velocity_rad_s[0].y;
    w_max = std::max(w_max, std::abs(wy));
    angle += wy * s.dt_s();
    angle_min = std::min(angle_min, angle);
    angle_max = std::max(angle_max, angle);
    drift = std::max(drift, norm(s.bodies().position_m[0] - Vec3{0, 0, kR - delta}));
  }
  report("spin-down: max |w| after the stop [rad/s]", w_max, m_lim / std::sqrt(k_r * inertia));
  report("spin-down: rotation range after the stop [rad]", angle_max - angle_min, 2 * m_lim / k_r);
  EXPECT_LT(w_max, 1.1 * m_lim / std::sqrt(k_r * inertia));
  EXPECT_LT(angle_max - angle_min, 1.1 * 2 * m_lim / k_r);
  EXPECT_LT(drift, 1e-9);  // it spun in place: no rolling without sliding friction
}

namespace {

struct InclineResult {
  double displacement_m = 0.0;       // along the slope over the whole run
  double late_displacement_m = 0.0;  // over the second half
  double acceleration_m_s2 = 0.0;    // fitted over the second half
  double slip_m_s = 0.0;             // v - w R at the end
  double rolling_torque_n_m = 0.0;   // |M_r| at the end
  double rolling_limit_n_m = 0.0;    // mu_r R |F_n| (static load)
};

InclineResult incline(double tan_theta) {
  const ScopedThreads one_thread(1);
  const double th = std::atan(tan_theta);
  sim::Simulation s = sphere_on_plane(th, 1.0);
  const double x0 = s.bodies().position_m[0].x;
  const int n = 20000;  // 0.2 s
  std::vector<double> t, v;
  double x_half = 0.0;
  for (int k = 1; k <= n; ++k) {
    s.step();
    if (k == n / 2) x_half = s.bodies().position_m[0].x;
    if (k > n / 2) {
      t.push_back(s.time_s());
      v.push_back(s.bodies().velocity_m_s[0].x);
    }
  }
  InclineResult r;
  const double x = s.bodies().position_m[0].x;
  r.displacement_m = x - x0;
  r.late_displacement_m = x - x_half;
  r.acceleration_m_s2 = fit_slope(t, v);
  r.slip_m_s = s.bodies().velocity_m_s[0].x - s.bodies().angular_velocity_rad_s[0].y * kR;
  r.rolling_torque_n_m = norm(s.wall_contacts().history[0].m_r);  // one sphere, one wall
  r.rolling_limit_n_m = kMuR * kR * sphere_mass_kg(kR, kBiomass.density_kg_m3) * kG * std::cos(th);
  return r;
}

}  // namespace

// Rolling limit on an incline. Derivation (rigid sphere, contact point at distance L = R - delta/2
// below the centre, which is where the engine applies the tangential force): at rest the
// friction force F balances the slope component of gravity, F = m g sin(theta), and its torque
// about the centre, F L, must be balanced by the rolling torque, whose magnitude is at most
// mu_r R* |F_n| = mu_r R m g cos(theta):
//     m g sin(theta) L <= mu_r R m g cos(theta)   <=>   tan(theta) <= mu_r R / L ~ mu_r (1 + delta / 2R),
// i.e. tan(theta) = mu_r to 2e-4 (delta / R ~ 3e-4). Above it the sphere rolls with the
// rolling torque at its limit: m a = m g sin - F, I a / L = F L - mu_r R m g cos, hence
//     a = g (sin(theta) - mu_r cos(theta) R / L) / (1 + I / (m L^2))  ~  (5/7) g (sin - mu_r cos).
// Sliding friction mu_s = 1 exceeds the friction either case needs (tan(theta) = 0.4 at rest;
// (2/7) tan + (5/7) mu_r = 0.53 rolling), so the sphere cannot slide.
// Both sides of the threshold with a 20 % margin, tan(theta) = 0.8 mu_r and 1.2 mu_r (the
// brief's), and again with 3 %, 0.97 mu_r and 1.03 mu_r, which locates the threshold itself:
//  - Below: it stays. Over the second half of the 0.2 s run it moves less than 1 nm (measured:
//    0); a rolling sphere moves mm. The rolling spring holds the static torque
//    m g sin(theta) L within 1 %. The sphere starts with unloaded springs, so they overshoot at
//    first (a step load on an undamped spring can double it) and briefly reach the plastic limit:
//    the sphere rolls a few um before it stops (measured 0.6 um at 0.8 mu_r, 4 um at 0.97 mu_r;
//    asserted < 20 um). Closer to the threshold (0.999 mu_r) that transient leaves it rolling
//    slowly for longer than the run, decelerating at only ~4e-3 m/s^2: hence the 3 % bracket.
//  - Above: it rolls; acceleration over the second half within 1 % of the formula above (at
//    1.03 mu_r the R / L correction is 0.5 %, and the measured value agrees with the corrected
//    formula to 1e-12), no slip (|v - w R| < 1e-3 v), rolling torque at the limit (1 %).
TEST(Epsd2, InclineHoldsBelowTanThetaEqualsMuRAndRollsAbove) {
  const double m = sphere_mass_kg(kR, kBiomass.density_kg_m3);
  for (const double margin : {0.2, 0.03}) {
    const std::string tag = "incline, margin " + std::to_string(margin).substr(0, 4);
    {
      const double tan_theta = (1.0 - margin) * kMuR, th = std::atan(tan_theta);
      const InclineResult r = incline(tan_theta);
      const double delta = hertz_static_overlap_m(m * kG * std::cos(th), kR, effective_young_pa(kBiomass, kBiomass));
      const double static_torque = m * kG * std::sin(th) * (kR - 0.5 * delta);
      const std::string t = tag + ", tan = (1 - margin) mu_r: ";
      report((t + "displacement over 0.2 s [m]").c_str(), r.displacement_m, 0.0);
      report((t + "displacement over the second 0.1 s [m]").c_str(), r.late_displacement_m, 0.0);
      report((t + "rolling torque held [N m]").c_str(), r.rolling_torque_n_m, static_torque);
      report((t + "rolling torque / limit").c_str(), r.rolling_torque_n_m / r.rolling_limit_n_m, 1.0 - margin);
      EXPECT_LT(std::abs(r.displacement_m), 20e-6) << t;
      EXPECT_LT(std::abs(r.late_displacement_m), 1e-9) << t;
      EXPECT_NEAR(r.rolling_torque_n_m / static_torque, 1.0, 0.01) << t;
    }
    {
      const double tan_theta = (1.0 + margin) * kMuR, th = std::atan(tan_theta);
      const InclineResult r = incline(tan_theta);
      const double delta = hertz_static_overlap_m(m * kG * std::cos(th), kR, effective_young_pa(kBiomass, kBiomass));
      const double l = kR - 0.5 * delta, inertia = 0.4 * m * kR * kR;
      const double a = kG * (std::sin(th) - kMuR * std::cos(th) * kR / l) / (1.0 + inertia / (m * l * l));
      const std::string t = tag + ", tan = (1 + margin) mu_r: ";
      report((t + "acceleration [m/s^2]").c_str(), r.acceleration_m_s2, a);
      report((t + "vs rigid-sphere (5/7) g (sin - mu_r cos) [m/s^2]").c_str(), r.acceleration_m_s2,
             5.0 / 7.0 * kG * (std::sin(th) - kMuR * std::cos(th)));
      report((t + "displacement over 0.2 s [m]").c_str(), r.displacement_m, 0.0);
      report((t + "rolling torque / limit").c_str(), r.rolling_torque_n_m / r.rolling_limit_n_m, 1.0);
      const double speed = a * 0.2;
      report((t + "|v - w R| / v").c_str(), std::abs(r.slip_m_s) / speed, 0.0);
      EXPECT_NEAR(r.acceleration_m_s2 / a, 1.0, 0.01) << t;
      EXPECT_GT(r.displacement_m, 1e-3) << t;
      EXPECT_LT(std::abs(r.slip_m_s), 1e-3 * speed) << t;
      EXPECT_NEAR(r.rolling_torque_n_m / r.rolling_limit_n_m, 1.0, 0.01) << t;
    }
  }
}
