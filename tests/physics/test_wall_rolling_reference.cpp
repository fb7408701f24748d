// EPSD2 at a turning wall, both conventions of SPEC 2.3 ([contact] wall_rolling_reference):
//   "wall" (default): w_rel = w_sphere - w_wall, the spin relative to the wall;
//   "lab" (LIGGGHTS 3.8.0): w_rel = w_sphere, the particle's own spin.
// Scene: a sphere at the bottom of a cylinder turning at omega about z, pressed into the mantle
// (overlap 2 um), carried round rigidly with it (centre velocity omega x r, spin omega z). Its
// spin is perpendicular to the contact normal, so it is rolling in the lab but not on the wall.
// At the first force evaluation (M_r starts at zero, one increment k_r w_t dt):
//   "wall": M_r = 0, the torque equals that of the same scene without rolling friction;
//   "lab":  M_r = k_r omega dt z with k_r = k_t R^2, k_t = 8 G* sqrt(R delta): the torque is
//           lower by exactly that (torque -M_r on the sphere).
// A sign error in the wall term (w_sphere + w_wall) doubles the "wall" increment; dropping the
// wall term makes "wall" equal "lab"; both fail the 1e-9 relative tolerance.
#include <gtest/gtest.h>

#include <cmath>

#include "physics_support.hpp"

using namespace biodem;
using namespace biodem::phys;

namespace {

constexpr double kR = 1.5e-3, kRc = 20e-3, kOmega = 2.0, kDelta = 2e-6;

double torque_z(double rolling_friction, bool lab) {
  SimSetup su;
  su.particle = {5e6, 0.3, 350.0};
  su.wall = {5e6, 0.3, 0.0};
  su.particle_wall = {0.1, 0.4, rolling_friction, 0.0};
  su.templates = {sphere_template(kR)};
  su.dt_s = 1e-5;
  sim::Simulation s = make_simulation(su);
  s.add_wall(cylinder_wall({0, 0, 0}, {0, 0, 1}, kRc, kOmega));
  s.set_wall_rolling_lab(lab);
  const Vec3 x{0, -(kRc - kR + kDelta), 0};
  add_particle(s, 0, x, cross(Vec3{0, 0, kOmega}, x), {0, 0, kOmega});
  s.refresh();  // the first force evaluation
  return s.bodies().torque_n_m[0].z;
}

}  // namespace

TEST(WallRollingReference, WallConventionSeesNoRollingOnACoRotatingSphere) {
  const double plain = torque_z(0.0, false), wall = torque_z(0.5, false);
  std::printf("[measured] co-rotating sphere, 'wall': torque %.6g N m, without rolling friction %.6g N m\n", wall, plain);
  EXPECT_NEAR(wall, plain, 1e-9 * std::abs(plain) + 1e-18);
}

TEST(WallRollingReference, LabConventionResistsTheCarriedSpin) {
  const double plain = torque_z(0.0, true), lab = torque_z(0.5, true);
  const Material m{5e6, 0.3, 350.0};
  const double k_t = 8.0 * effective_shear_pa(m, m) * std::sqrt(kR * kDelta);
  const double expected = -k_t * kR * kR * kOmega * 1e-5;
  // below the plastic limit mu_r R |F_n| for the test to see the spring increment
  const double f_n = 4.0 / 3.0 * effective_young_pa(m, m) * std::sqrt(kR) * std::pow(kDelta, 1.5);
  ASSERT_LT(std::abs(expected), 0.5 * kR * f_n);
  report("'lab' rolling torque increment (N m)", lab - plain, expected);
  EXPECT_NEAR(lab - plain, expected, 1e-9 * std::abs(expected));
}
