// Tests for the blind spots listed in issue 10, item 10 (those that need no engine change):
//  1. m* = body mass for clump spheres: a two-sphere clump hitting a wall (or another clump)
//     along its axis moves as a point mass M; its rebound must equal that of a single sphere of
//     the same radius and mass M. With the sphere's own mass (M/2) in m*, the normal dashpot
//     gamma_n ~ sqrt(m*) would be sqrt(2) too weak and the restitution visibly higher.
//  2. Pair EPSD2 dynamics: two spheres stacked on a frictionless plane, the top one spinning;
//     the pair's rolling torque mu_r R* |F_n| (R* = R/2) brakes it and spins up the lower one.
//  3. Clumps colliding across a periodic boundary: linear momentum, and angular momentum
//     computed with the image position, are conserved.
// None of them found a bug in the engine (measured: clump rebound = sphere of the body mass to
// 3e-15; pair rolling deceleration to 2e-12; momentum to 1e-15, angular momentum to 7e-14).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "physics_support.hpp"

using namespace biodem;
using namespace biodem::phys;

namespace {

constexpr double kG = 9.81;
constexpr double kR = 1e-3;
const Material kSoft{5e6, 0.3, 1000.0};
constexpr double kE = 0.5;  // restitution of the impacts

/// Body index of the body with the given id (spatial sorting may reorder bodies).
std::size_t index_of(const sim::Simulation& s, std::uint32_t id) {
  for (std::size_t b = 0; b < s.bodies().size(); ++b)
    if (s.bodies().id[b] == id) return b;
  ADD_FAILURE() << "no body " << id;
  return 0;
}

/// Runs until every contact has ended (after at least one); returns the step count.
void run_through_impact(sim::Simulation& s) {
  bool touched = false;
  for (int k = 0; k < 400000; ++k) {
    s.step();
    if (s.contact_count() > 0) touched = true;
    else if (touched) return;
  }
  ADD_FAILURE() << "impact did not end";
}

/// Two touching spheres of radius kR on the z axis (a dumbbell clump), density rho.
shapes::ClumpTemplate dumbbell() { return clump_template({{0, 0, -kR}, {0, 0, kR}}, {kR, kR}); }

/// Unit vector along the clump's sphere axis, from its first to its second sphere.
Vec3 clump_axis(const sim::Simulation& s, std::size_t b) {
  const auto& sp = s.spheres();
  const std::uint32_t s0 = s.bodies().first_sphere[b];
  return normalized(sp.position_m[s0 + 1] - sp.position_m[s0]);
}

SimSetup impact_setup(double density, const shapes::ClumpTemplate& t) {
  SimSetup su;
  su.particle = {kSoft.young_pa, kSoft.poisson, density};
  su.wall = kSoft;
  su.particle_particle = {kE, 0.0, 0.0, 0.0};
  su.particle_wall = su.particle_particle;
  su.templates = {t};
  su.dt_s = 2e-7;  // Hertz contact time ~ 0.1 ms at 1 m/s: > 500 steps
  return su;
}

}  // namespace

// 1a. Clump on a wall, along its axis, at 1 m/s: rebound speed equal to that of a sphere of the
// body's mass, to 1e-6 (measured 3e-15).
TEST(BlindSpots, ClumpWallImpactUsesBodyMassInDamping) {
  const ScopedThreads one(1);
  const double v0 = 1.0;
  sim::Simulation c = make_simulation(impact_setup(kSoft.density_kg_m3, dumbbell()));
  add_particle(c, 0, {0, 0, 0});
  const Vec3 a = clump_axis(c, 0);
  const double mass = c.bodies().mass_kg[0];
  ASSERT_NEAR(mass, 2.0 * sphere_mass_kg(kR, kSoft.density_kg_m3), 0.02 * mass);
  // Wall below the first sphere (normal +a), the clump moving towards it.
  c.add_wall(plane_wall(-(2 * kR + 1e-6) * a, a));
  c.bodies_mut().velocity_m_s[0] = -v0 * a;
  run_through_impact(c);
  const double v_clump = dot(c.bodies().velocity_m_s[0], a);

  sim::Simulation s = make_simulation(impact_setup(mass / sphere_volume_m3(kR), sphere_template(kR)));
  add_particle(s, 0, {0, 0, 0}, {0, 0, -v0});
  s.add_wall(plane_wall({0, 0, -(kR + 1e-6)}, {0, 0, 1}));
  run_through_impact(s);
  const double v_sphere = s.bodies().velocity_m_s[0].z;
  ASSERT_NEAR(s.bodies().mass_kg[0], mass, 1e-12 * mass);

  report("clump-wall rebound speed vs sphere of the body mass [m/s]", v_clump, v_sphere);
  EXPECT_GT(v_sphere, 0.3 * v0);  // it rebounded
  EXPECT_NEAR(v_clump, v_sphere, 1e-6 * v_sphere);
  EXPECT_LT(norm(c.bodies().angular_velocity_rad_s[0]), 1e-9);  // a central impact: no spin
  // What m* = sphere mass (M/2) would give: the dashpot sqrt(2) too weak, i.e. a sphere of mass M
  // with beta / sqrt(2), whose restitution e' = exp(beta' pi / sqrt(1 - beta'^2)) is 0.62, not
  // 0.5. The clump's rebound must be far from that (the test can tell the two apart).
  const double beta = beta_from_restitution(kE) / std::sqrt(2.0);
  const double e_wrong = std::exp(beta * std::numbers::pi / std::sqrt(1.0 - beta * beta));
  SimSetup wrong = impact_setup(mass / sphere_volume_m3(kR), sphere_template(kR));
  wrong.particle_wall.restitution = e_wrong;
  sim::Simulation h = make_simulation(wrong);
  add_particle(h, 0, {0, 0, 0}, {0, 0, -v0});
  h.add_wall(plane_wall({0, 0, -(kR + 1e-6)}, {0, 0, 1}));
  run_through_impact(h);
  report("rebound speed with m* = sphere mass (what the clump must not give) [m/s]", h.bodies().velocity_m_s[0].z,
         v_clump);
  EXPECT_GT(h.bodies().velocity_m_s[0].z - v_clump, 0.1 * v_clump);
}

// 1b. Two clumps head-on along their common axis, each at 0.5 m/s: m* = M/2, as for two spheres
// of mass M each; the rebound speeds must agree to 1e-5 (measured 5e-7; m* = M/4 would give
// a restitution of 0.62 instead of 0.5).
TEST(BlindSpots, ClumpClumpImpactUsesBodyMassesInDamping) {
  const ScopedThreads one(1);
  const double v0 = 0.5;
  sim::Simulation c = make_simulation(impact_setup(kSoft.density_kg_m3, dumbbell()));
  add_particle(c, 0, {0, 0, 0});
  const Vec3 a = clump_axis(c, 0);
  add_particle(c, 0, (4 * kR + 1e-6) * a);
  const double mass = c.bodies().mass_kg[0];
  c.bodies_mut().velocity_m_s[0] = v0 * a;
  c.bodies_mut().velocity_m_s[1] = -v0 * a;
  run_through_impact(c);
  const double v_clump = dot(c.bodies().velocity_m_s[index_of(c, 1)], a);

  sim::Simulation s = make_simulation(impact_setup(mass / sphere_volume_m3(kR), sphere_template(kR)));
  add_particle(s, 0, {0, 0, 0}, {0, 0, v0});
  add_particle(s, 0, {0, 0, 2 * kR + 1e-6}, {0, 0, -v0});
  run_through_impact(s);
  const double v_sphere = s.bodies().velocity_m_s[index_of(s, 1)].z;
  report("clump-clump rebound speed vs spheres of the body mass [m/s]", v_clump, v_sphere);
  EXPECT_GT(v_sphere, 0.3 * v0);
  EXPECT_NEAR(v_clump, v_sphere, 1e-5 * v_sphere);
}

// 2. Pair EPSD2. Sphere B rests on a plane (wall: no friction, no rolling friction), sphere A
// sits on top of B (pair: mu = 0, so no tangential force and nothing can roll off; mu_r = 0.5).
// A spins about y at w0 = 200 rad/s. The pair's rolling spring saturates at once, so
//     I dw_A/dt = -mu_r R* |F_n|,   I dw_B/dt = +mu_r R* |F_n|,   R* = R/2, |F_n| = m g,
// i.e. |dw/dt| = 1.25 mu_r g / R for each (1 % tolerance: R* = R or a wrong sign fails), and
// w_A + w_B is conserved; relative rotation stops at w_A = w_B = w0/2.
TEST(BlindSpots, PairRollingTorqueIsMuRTimesReducedRadiusTimesNormalForce) {
  const ScopedThreads one(1);
  constexpr double kMuR = 0.5, w0 = 200.0;
  SimSetup su;
  su.particle = kSoft;
  su.wall = kSoft;
  su.particle_particle = {0.1, 0.0, kMuR, 0.0};
  su.particle_wall = {0.1, 0.0, 0.0, 0.0};
  su.templates = {sphere_template(kR)};
  su.dt_s = 2e-6;
  su.gravity_m_s2 = {0, 0, -kG};
  sim::Simulation s = make_simulation(su);
  s.add_wall(plane_wall({0, 0, 0}, {0, 0, 1}));
  const double m = sphere_mass_kg(kR, kSoft.density_kg_m3);
  const double y_eff = effective_young_pa(kSoft, kSoft);
  const double z_b = kR - hertz_static_overlap_m(2 * m * kG, kR, y_eff);
  const double z_a = z_b + 2 * kR - hertz_static_overlap_m(m * kG, 0.5 * kR, y_eff);
  add_particle(s, 0, {0, 0, z_b});
  add_particle(s, 0, {0, 0, z_a});
  s.run_steps(5000);  // settle (10 ms; e = 0.1)
  s.bodies_mut().angular_velocity_rad_s[index_of(s, 1)] = {0, w0, 0};
  s.mark_spheres_stale();
  s.refresh();
  const double expected = 1.25 * kMuR * kG / kR;
  std::vector<double> t, wa, wb;
  double w_sum_dev = 0.0;
  for (int k = 0; k < 20000; ++k) {  // at most 40 ms (expected stop: w0 / (2 * expected) = 24 ms)
    s.step();
    const std::size_t ia = index_of(s, 1), ib = index_of(s, 0);
    const double a = s.bodies().angular_velocity_rad_s[ia].y, b = s.bodies().angular_velocity_rad_s[ib].y;
    w_sum_dev = std::max(w_sum_dev, std::abs(a + b - w0));
    if (a < 0.95 * w0 && a > 0.6 * w0) {
      t.push_back(s.time_s());
      wa.push_back(a);
      wb.push_back(b);
    }
    if (a - b <= 0.0) break;
  }
  ASSERT_GT(t.size(), 100u);
  const double rate_a = fit_slope(t, wa), rate_b = fit_slope(t, wb);
  report("pair EPSD2: dw/dt of the spinning sphere [rad/s^2]", rate_a, -expected);
  report("pair EPSD2: dw/dt of the sphere below [rad/s^2]", rate_b, expected);
  EXPECT_NEAR(rate_a / -expected, 1.0, 0.01);
  EXPECT_NEAR(rate_b / expected, 1.0, 0.01);
  EXPECT_LT(w_sum_dev, 1e-6 * w0);
  const std::size_t ia = index_of(s, 1);
  const double wa_end = s.bodies().angular_velocity_rad_s[ia].y;
  EXPECT_NEAR(wa_end, 0.5 * w0, 0.02 * w0);
  // Nothing rolled off: both still on the z axis.
  EXPECT_LT(std::hypot(s.bodies().position_m[ia].x, s.bodies().position_m[ia].y), 1e-9);
}

// 3. Two three-sphere needles collide through the periodic boundary of x in [0, 20 mm) (one near
// x = 18 mm moving +x, one near x = 2 mm moving -x, offset in y so the impact is eccentric and
// both start tumbling), frictional (mu = 0.5) and inelastic (e = 0.5). Linear momentum must be
// conserved to round-off; angular momentum about the origin, with the second needle taken at its
// image x + L (where the first one meets it), to the integrator's accuracy; energy must not grow.
TEST(BlindSpots, ClumpsCollidingAcrossPeriodicBoundaryConserveMomentum) {
  const ScopedThreads one(1);
  constexpr double kL = 20e-3, r = 0.5e-3;
  SimSetup su;
  su.particle = kSoft;
  su.wall = kSoft;
  su.particle_particle = {0.5, 0.5, 0.0, 0.0};
  su.particle_wall = su.particle_particle;
  su.templates = {clump_template({{-r, 0, 0}, {0, 0, 0}, {r, 0, 0}}, {r, r, r})};
  su.dt_s = 2e-7;
  sim::Simulation s = make_simulation(su);
  neighbor::Domain d;
  d.periodic = {true, false, false};
  d.lo_m = {0, 0, 0};
  d.hi_m = {kL, 0, 0};
  s.set_domain(d);
  // The template's long axis: rotate both so the needles lie along x, y (a T-shaped meeting).
  add_particle(s, 0, {kL - 3e-3, 0.0, 0}, {0.5, 0, 0}, {0, 0, 30.0});
  add_particle(s, 0, {2e-3, 0.6e-3, 0}, {-0.5, 0.1, 0}, {0, 0, -20.0},
               Quat{std::cos(0.4), 0, 0, std::sin(0.4)});
  auto momentum = [&]() {
    Vec3 p;
    for (std::size_t b = 0; b < s.bodies().size(); ++b) p += s.bodies().mass_kg[b] * s.bodies().velocity_m_s[b];
    return p;
  };
  auto angular = [&]() {
    Vec3 l;
    for (std::size_t b = 0; b < s.bodies().size(); ++b) {
      Vec3 x = s.bodies().position_m[b];
      if (s.bodies().id[b] == 1) x.x += kL;
      l += cross(x, s.bodies().mass_kg[b] * s.bodies().velocity_m_s[b]) + s.bodies().angular_momentum_kg_m2_s[b];
    }
    return l;
  };
  s.refresh();
  const Vec3 p0 = momentum(), l0 = angular();
  const double ke0 = s.kinetic_energy_j();
  const double p_scale = s.bodies().mass_kg[0] * 1.0;  // sum of m |v|
  const Vec3 v1_before = s.bodies().velocity_m_s[index_of(s, 1)];
  double p_dev = 0.0, l_dev = 0.0;
  bool touched = false;
  for (int k = 0; k < 200000; ++k) {
    s.step();
    p_dev = std::max(p_dev, norm(momentum() - p0) / p_scale);
    l_dev = std::max(l_dev, norm(angular() - l0));
    if (s.contact_count() > 0) touched = true;
    else if (touched) break;
  }
  ASSERT_TRUE(touched) << "the needles did not meet";
  const Vec3 v1_after = s.bodies().velocity_m_s[index_of(s, 1)];
  const double l_scale = p_scale * 2e-3;  // momentum times the lever of the impact
  report("periodic clump collision: max |P - P0| / sum m|v|", p_dev, 0.0);
  report("periodic clump collision: max |L - L0| / (sum m|v| x 2 mm)", l_dev / l_scale, 0.0);
  report("periodic clump collision: KE after / before", s.kinetic_energy_j() / ke0, 1.0);
  EXPECT_GT(norm(v1_after - v1_before), 0.2);  // a real collision
  EXPECT_LT(p_dev, 1e-12);
  EXPECT_LT(l_dev / l_scale, 1e-4);
  EXPECT_LT(s.kinetic_energy_j(), ke0);
}
