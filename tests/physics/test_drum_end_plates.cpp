// The drum's end plates turn with the drum (SPEC 5), and a sphere resting on either plate is
// dragged by it: drum of SPEC 5 built by scenario::add_drum (diameter 100 mm, width 20 mm,
// 60 rpm, omega = 2 pi rad/s), a sphere R = 2 mm 30 mm below the axis, pressed onto the front
// plate (z = 0) or the back plate (z = 20 mm) by gravity along the axis (g = 9.81 m/s^2 towards
// the plate), mu = 0.5, no rolling resistance. The plate's surface under the sphere moves at
// V = omega * 30 mm = 0.188 m/s along +x for both plates (the drum turns counter-clockwise seen
// from +z).
//
// Theory (rigid sphere on a plane moving at V, as the rotating cylinder test): the sphere slips
// until its contact point moves with the plate, which takes (2/7) V / (mu g) = 11 ms; the centre
// then moves at u = (2/7) V = 0.0539 m/s and rolls on. Tolerance 2 % at t = 25 ms, measured
// 0.05 % (the plate's speed under the sphere changes by less than 3 % while the sphere moves
// ~1 mm; the Mindlin spring's first steps): a counter-rotating back plate would give -u, a drum
// at half speed u/2.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include "physics_support.hpp"
#include "scenario/drum.hpp"

using namespace biodem;
using namespace biodem::phys;

namespace {

constexpr double kR = 2e-3, kG = 9.81, kWidth = 20e-3, kY = -30e-3;
const Material kPolymer{1e8, 0.3, 2500.0};

/// The drum of these tests (diameter 100 mm, width kWidth, polymer spheres R = kR, mu = 0.5),
/// built by scenario::add_drum.
sim::Simulation drum_scene(double gravity_z, double rpm, bool periodic_axis) {
  SimSetup su;
  su.particle = kPolymer;
  su.wall = kPolymer;
  su.particle_wall = {0.5, 0.5, 0.0, 0.0};
  su.particle_particle = su.particle_wall;
  su.templates = {sphere_template(kR)};
  su.dt_s = 5e-6;  // ~9 % of the Rayleigh time
  su.gravity_m_s2 = {0, 0, gravity_z};
  sim::Simulation s = make_simulation(su);
  scenario::DrumGeometry d;
  d.diameter_m = 0.1;
  d.width_m = kWidth;
  d.rpm = rpm;
  d.mantle_material = kWall;
  d.endplate_material = kWall;
  d.periodic_axis = periodic_axis;
  scenario::add_drum(s, d);
  return s;
}

/// Centre velocity (x, y) of the sphere after 25 ms on the front (z = 0) or back plate.
Vec3 dragged(bool back) {
  sim::Simulation s = drum_scene(back ? kG : -kG, 60.0, false);
  s.set_drum_rotation(true);
  const double m = sphere_mass_kg(kR, kPolymer.density_kg_m3);
  const double d0 = hertz_static_overlap_m(m * kG, kR, effective_young_pa(kPolymer, kPolymer));
  add_particle(s, 0, {0, kY, back ? kWidth - (kR - d0) : kR - d0});
  for (int k = 0; k < 5000; ++k) s.step();  // 25 ms
  return s.bodies().velocity_m_s[0];
}

}  // namespace

TEST(DrumEndPlates, BothPlatesDragARestingSphereTheWayTheDrumTurns) {
  const ScopedThreads one_thread(1);
  const double v_plate = 2.0 * std::numbers::pi * -kY;  // omega * 30 mm
  const double u = 2.0 / 7.0 * v_plate;
  for (const bool back : {false, true}) {
    const Vec3 v = dragged(back);
    report(back ? "back plate: sphere centre v_x [m/s]" : "front plate: sphere centre v_x [m/s]", v.x, u);
    EXPECT_NEAR(v.x / u, 1.0, 0.02) << (back ? "back" : "front") << " plate";
    EXPECT_LT(std::abs(v.y), 0.1 * u) << (back ? "back" : "front") << " plate";
    EXPECT_LT(std::abs(v.z), 1e-3 * u) << "the sphere stays on the plate";
  }
}

// A drum with a periodic axis (SPEC 5's periodic option: no end plates, the bed repeats along the
// axis with the drum's width as its period): two spheres R = 2 mm at the same (x, y), one 1.9 mm
// above z = 0 and one 1.9 mm below z = W, touch through the seam with an overlap of 0.2 mm.
// Each is pushed away from the seam by the static Hertz force (4/3) Y* sqrt(R/2) delta^(3/2)
// (at rest: no damping, no tangential force), equal and opposite. Tolerance 1e-9 relative. A
// period other than W (e.g. 2W: a drum twice as wide, half filled) leaves them apart (checked),
// and so would an image shifted the wrong way.
TEST(PeriodicDrum, SpheresTouchAcrossTheSeam) {
  sim::Simulation s = drum_scene(0.0, 0.0, true);
  EXPECT_EQ(s.domain().length_m().z, kWidth);
  const double gap = 1.9e-3, delta = 2 * kR - 2 * gap;
  add_particle(s, 0, {0, kY, gap});
  add_particle(s, 0, {0, kY, kWidth - gap});
  s.refresh();
  const Vec3 f_low = s.spheres().force_n[0], f_high = s.spheres().force_n[1];
  const double expect = 4.0 / 3.0 * effective_young_pa(kPolymer, kPolymer) * std::sqrt(0.5 * kR) * std::pow(delta, 1.5);
  std::printf("[measured] periodic drum: force across the seam %.9g N on the low sphere, %.9g N on the high one "
              "(Hertz %.9g N)\n", f_low.z, f_high.z, expect);
  EXPECT_NEAR(f_low.z, expect, 1e-9 * expect);
  EXPECT_NEAR(f_high.z, -expect, 1e-9 * expect);
  EXPECT_NEAR(std::hypot(f_low.x, f_low.y), 0.0, 1e-12 * expect);
  EXPECT_EQ(s.contact_count(), 1u);
}
