// Normal impacts driven through the Simulation (SPEC 2.2, 10): the measured coefficient of
// restitution equals the input e, and an elastic impact lasts as long and pushes as hard as
// Hertz theory says (Johnson, Contact Mechanics, 1985, sec. 11.4).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "physics_support.hpp"

using namespace biodem;
using namespace biodem::phys;

namespace {

struct ImpactResult {
  Vec3 velocity_after_m_s;     // body 0, first step with no contact after the impact
  Vec3 spin_after_rad_s;       // body 0
  double contact_time_s = 0.0; // steps with an open contact x dt
  double peak_force_n = 0.0;   // largest |force| on body 0 during the contact
};

/// Steps until the first contact has opened and closed again (or max_steps).
ImpactResult run_impact(sim::Simulation& s, std::uint64_t max_steps) {
  ImpactResult r;
  bool touched = false;
  std::uint64_t contact_steps = 0;
  for (std::uint64_t k = 0; k < max_steps; ++k) {
    s.step();
    if (s.contact_count() > 0) {
      touched = true;
      ++contact_steps;
      r.peak_force_n = std::max(r.peak_force_n, norm(s.bodies().force_n[0]));
    } else if (touched) {
      break;
    }
  }
  EXPECT_TRUE(touched) << "no contact happened";
  EXPECT_EQ(s.contact_count(), 0u) << "contact did not end within the step budget";
  r.velocity_after_m_s = s.bodies().velocity_m_s[0];
  r.spin_after_rad_s = s.bodies().angular_velocity_rad_s[0];
  r.contact_time_s = static_cast<double>(contact_steps) * s.dt_s();
  return r;
}

}  // namespace

// 1. Sphere (glass, R = 1 mm) dropped normally on a steel plane at 1 m/s, no gravity.
// Tolerance 1 %: the damped Hertz law with beta from e gives exactly e for the continuous
// equation of motion (checked independently by a 20 000-step ODE integration: 1e-5). The time
// step is dt = t_c/1000 (t_c: elastic Hertz time; the e = 0.1 contact lasts ~1.5 t_c). The
// dashpot sees the half-step velocity of velocity Verlet (as in LIGGGHTS), which makes the
// damping term first order in dt: e = 0.1 comes out ~0.9 % low at dt = t_c/200 and ~0.2 % low
// at t_c/1000 (same numbers from a stand-alone integration of the same scheme). Velocities
// are read on the first step without contact, when no force acts any more.
TEST(NormalImpact, SphereWallRestitutionEqualsInput) {
  const ScopedThreads one_thread(1);
  const double r = 1e-3, v0 = 1.0;
  const Material glass{70e9, 0.22, 2500.0};
  const Material steel{200e9, 0.30, 0.0};
  const double m = sphere_mass_kg(r, glass.density_kg_m3);
  const double t_c = hertz_contact_time_s(m, r, effective_young_pa(glass, steel), v0);
  for (const double e : {0.1, 0.5, 0.87, 0.98}) {
    SimSetup su;
    su.particle = glass;
    su.wall = steel;
    su.particle_wall = {e, 0.0, 0.0, 0.0};
    su.particle_particle = su.particle_wall;
    su.templates = {sphere_template(r)};
    su.dt_s = t_c / 1000.0;
    sim::Simulation s = make_simulation(su);
    s.add_wall(plane_wall({0, 0, 0}, {0, 0, 1}));
    add_particle(s, 0, {0, 0, r + 2e-6}, {0, 0, -v0});
    const ImpactResult res = run_impact(s, 40000);
    const double e_measured = res.velocity_after_m_s.z / v0;
    report(("sphere-wall restitution, e = " + std::to_string(e)).c_str(), e_measured, e);
    EXPECT_NEAR(e_measured / e, 1.0, 0.01) << "e = " << e;
    EXPECT_NEAR(res.velocity_after_m_s.x, 0.0, 1e-12);
    EXPECT_NEAR(res.velocity_after_m_s.y, 0.0, 1e-12);
  }
}

// Same for a head-on sphere-sphere impact (two equal spheres at +-v0/2): the pair uses m* = m/2.
TEST(NormalImpact, SphereSphereRestitutionEqualsInput) {
  const ScopedThreads one_thread(1);
  const double r = 1e-3, v_rel = 1.0;
  const Material glass{70e9, 0.22, 2500.0};
  const double m = sphere_mass_kg(r, glass.density_kg_m3);
  const double t_c = hertz_contact_time_s(0.5 * m, 0.5 * r, effective_young_pa(glass, glass), v_rel);
  for (const double e : {0.1, 0.5, 0.87, 0.98}) {
    SimSetup su;
    su.particle = glass;
    su.wall = glass;
    su.particle_particle = {e, 0.0, 0.0, 0.0};
    su.particle_wall = su.particle_particle;
    su.templates = {sphere_template(r)};
    su.dt_s = t_c / 1000.0;
    sim::Simulation s = make_simulation(su);
    add_particle(s, 0, {-(r + 1e-6), 0, 0}, {0.5 * v_rel, 0, 0});
    add_particle(s, 0, {r + 1e-6, 0, 0}, {-0.5 * v_rel, 0, 0});
    const ImpactResult res = run_impact(s, 40000);
    const double e_measured = (s.bodies().velocity_m_s[1].x - s.bodies().velocity_m_s[0].x) / v_rel;
    report(("sphere-sphere restitution, e = " + std::to_string(e)).c_str(), e_measured, e);
    EXPECT_NEAR(e_measured / e, 1.0, 0.01) << "e = " << e;
    (void)res;
  }
}

// 2. Elastic (e = 1) head-on impacts of glass spheres (R = 10 mm, E = 48 GPa, nu = 0.2,
// rho = 2800). Theory: t_c = 2.868 (m*^2/(R* Y*^2 v))^(1/5), F_max = (4/3) Y* sqrt(R*) d^1.5,
// d = (15 m* v^2/(16 Y* sqrt(R*)))^(2/5). Tolerance 2 %: the contact time is counted in whole
// steps (dt = t_c/1000, so +-0.1 %), the peak force is sampled at steps (relative error
// O((dt/t_c)^2) ~ 1e-5 near the smooth maximum); the 2.868 prefactor itself is rounded to
// 4 digits (Johnson's 2.87). The theory values are also pinned to the literal numbers
// 40.3 us / 10.7 kN within 1 % (both are quoted to 3 digits).
TEST(NormalImpact, ElasticSphereSphereMatchesHertzTimeAndForce) {
  const ScopedThreads one_thread(1);
  const double r = 10e-3, v = 10.0;  // each sphere; relative speed 20 m/s
  const Material glass{48e9, 0.2, 2800.0};
  const double m = sphere_mass_kg(r, glass.density_kg_m3);
  const double m_eff = 0.5 * m, r_eff = 0.5 * r, y_eff = effective_young_pa(glass, glass);
  const double t_theory = hertz_contact_time_s(m_eff, r_eff, y_eff, 2.0 * v);
  const double f_theory = hertz_peak_force_n(m_eff, r_eff, y_eff, 2.0 * v);
  EXPECT_NEAR(t_theory / 40.3e-6, 1.0, 0.01);
  EXPECT_NEAR(f_theory / 10.7e3, 1.0, 0.01);

  SimSetup su;
  su.particle = glass;
  su.wall = glass;
  su.particle_particle = {1.0, 0.0, 0.0, 0.0};
  su.particle_wall = su.particle_particle;
  su.templates = {sphere_template(r)};
  su.dt_s = t_theory / 1000.0;
  sim::Simulation s = make_simulation(su);
  add_particle(s, 0, {-(r + 5e-6), 0, 0}, {v, 0, 0});
  add_particle(s, 0, {r + 5e-6, 0, 0}, {-v, 0, 0});
  const ImpactResult res = run_impact(s, 10000);
  report("elastic sphere-sphere contact time [s]", res.contact_time_s, t_theory);
  report("elastic sphere-sphere peak force [N]", res.peak_force_n, f_theory);
  EXPECT_NEAR(res.contact_time_s / t_theory, 1.0, 0.02);
  EXPECT_NEAR(res.peak_force_n / f_theory, 1.0, 0.02);
  // e = 1: the spheres separate with their impact speeds (Verlet error ~ (dt/t_c)^2).
  report("elastic sphere-sphere rebound speed [m/s]", -res.velocity_after_m_s.x, v);
  EXPECT_NEAR(-res.velocity_after_m_s.x / v, 1.0, 1e-3);
}

// Sphere-wall at 10 m/s on a wall of the same glass (the wall's own E and nu enter Y*;
// R* = R, m* = m). Same tolerances as above.
TEST(NormalImpact, ElasticSphereWallMatchesHertzTimeAndForce) {
  const ScopedThreads one_thread(1);
  const double r = 10e-3, v = 10.0;
  const Material glass{48e9, 0.2, 2800.0};
  const double m = sphere_mass_kg(r, glass.density_kg_m3);
  const double y_eff = effective_young_pa(glass, glass);
  const double t_theory = hertz_contact_time_s(m, r, y_eff, v);
  const double f_theory = hertz_peak_force_n(m, r, y_eff, v);

  SimSetup su;
  su.particle = glass;
  su.wall = glass;
  su.particle_wall = {1.0, 0.0, 0.0, 0.0};
  su.particle_particle = su.particle_wall;
  su.templates = {sphere_template(r)};
  su.dt_s = t_theory / 1000.0;
  sim::Simulation s = make_simulation(su);
  s.add_wall(plane_wall({0, 0, 0}, {0, 0, 1}));
  add_particle(s, 0, {0, 0, r + 5e-6}, {0, 0, -v});
  const ImpactResult res = run_impact(s, 10000);
  report("elastic sphere-wall contact time [s]", res.contact_time_s, t_theory);
  report("elastic sphere-wall peak force [N]", res.peak_force_n, f_theory);
  EXPECT_NEAR(res.contact_time_s / t_theory, 1.0, 0.02);
  EXPECT_NEAR(res.peak_force_n / f_theory, 1.0, 0.02);
  report("elastic sphere-wall rebound speed [m/s]", res.velocity_after_m_s.z, v);
  EXPECT_NEAR(res.velocity_after_m_s.z / v, 1.0, 1e-3);
}
