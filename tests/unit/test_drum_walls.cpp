// The drum's walls turn together (SPEC 5): mantle and both end plates have the same lab angular
// velocity +omega z (counter-clockwise seen from +z for positive rpm), so the wall surface below
// the axis moves towards +x, where the bed rises. A wrong sign on the back plate (normal -z)
// would make it counter-rotate.
#include <gtest/gtest.h>

#include <numbers>

#include "scenario/drum.hpp"
#include "walls/wall_geometry.hpp"

using namespace biodem;

TEST(DrumWalls, AllWallsTurnWithTheSameLabAngularVelocity) {
  config::Shape s;
  s.name = "b";
  s.diameter_m = 1e-3;
  contact::PairTable pairs(1);
  sim::Simulation sim({shapes::make_template(s, 1.0)}, {2500.0}, pairs, 1e-5, Vec3{0, -9.81, 0});
  scenario::DrumGeometry d;
  d.diameter_m = 0.1;
  d.width_m = 0.005;
  d.rpm = 6.0;
  scenario::add_drum(sim, d);
  ASSERT_EQ(sim.walls().size(), 3u);
  for (const auto& w : sim.walls()) EXPECT_EQ(w.geometry.angular_velocity_rad_s, 0.0);  // rotation off by default
  sim.set_drum_rotation(true);
  const double omega = 6.0 * 2.0 * std::numbers::pi / 60.0;
  for (const auto& w : sim.walls()) {
    const Vec3 lab = w.geometry.angular_velocity_rad_s * w.geometry.normal;
    EXPECT_NEAR(lab.z, omega, 1e-15);
    EXPECT_NEAR(lab.x, 0.0, 1e-15);
    // Surface velocity at the bottom of the drum (y = -R) points to +x with speed omega R.
    const Vec3 v = walls::wall_velocity(w.geometry, Vec3{0.0, -0.05, w.geometry.point_m.z});
    EXPECT_NEAR(v.x, omega * 0.05, 1e-15);
    EXPECT_NEAR(v.y, 0.0, 1e-15);
  }
  sim.set_drum_rotation(false);
  for (const auto& w : sim.walls()) EXPECT_EQ(w.geometry.angular_velocity_rad_s, 0.0);
}

// rpm < 0 turns the drum clockwise seen from +z (SPEC 6's mirror case): the lab angular velocity
// is -|omega| z and the wall below the axis moves towards -x.
TEST(DrumWalls, NegativeRpmTurnsClockwise) {
  scenario::DrumGeometry d;
  d.rpm = -0.5;
  EXPECT_NEAR(d.angular_velocity_rad_s(), -0.5 * 2.0 * std::numbers::pi / 60.0, 1e-17);
  EXPECT_NEAR(d.angular_velocity_rad_s(), -0.0523598775598299, 1e-15);
  config::Shape s;
  s.name = "b";
  s.diameter_m = 1e-3;
  contact::PairTable pairs(1);
  sim::Simulation sim({shapes::make_template(s, 1.0)}, {2500.0}, pairs, 1e-5, Vec3{0, -9.81, 0});
  d.diameter_m = 0.1;
  d.width_m = 0.005;
  scenario::add_drum(sim, d);
  sim.set_drum_rotation(true);
  for (const auto& w : sim.walls()) {
    EXPECT_NEAR((w.geometry.angular_velocity_rad_s * w.geometry.normal).z, -0.0523598775598299, 1e-15);
    const Vec3 v = walls::wall_velocity(w.geometry, Vec3{0.0, -0.05, w.geometry.point_m.z});
    EXPECT_NEAR(v.x, -0.0523598775598299 * 0.05, 1e-15);
  }
}
