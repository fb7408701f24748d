// The rotating drum of SPEC 5: a cylindrical mantle about the z axis through the origin and two
// end plates at z = 0 and z = width (or a periodic z axis), all turning together. Rotation is
// counter-clockwise seen from +z for positive rpm, so the bed rises on the +x side.
#pragma once
#include <numbers>

#include "sim/simulation.hpp"

namespace biodem::scenario {

struct DrumGeometry {
  double diameter_m = 0.0;
  double width_m = 0.0;
  double rpm = 0.0;
  std::uint16_t mantle_material = 0;
  std::uint16_t endplate_material = 0;
  bool periodic_axis = false;

  double radius_m() const { return 0.5 * diameter_m; }
  double angular_velocity_rad_s() const { return rpm * 2.0 * std::numbers::pi / 60.0; }
  double volume_m3() const { return std::numbers::pi * radius_m() * radius_m() * width_m; }
};

/// Adds the mantle and (unless periodic) the end plates as drum walls, sets the drum angular
/// velocity (rotation stays off until the driver switches it on) and, for a periodic axis, the
/// periodic domain along z.
void add_drum(sim::Simulation& sim, const DrumGeometry& drum);

}  // namespace biodem::scenario
