// A wall's prescribed translation (SPEC 7 bulk tests: the heap's lifted cylinder, the shear
// box's gate): where the wall is at time t and how fast its surface moves. One pure function for
// the CPU engine (sim::Simulation::update_wall_motion) and the GPU engine (gpu::MoveWalls), so
// both put a moving wall at the same place to the bit.
#pragma once
#include "core/hd.hpp"
#include "core/vec3.hpp"
#include "walls/wall_geometry.hpp"

namespace biodem::walls {

/// The schedule: at rest at initial_point_m until start_s, at velocity_m_s from start_s to end_s,
/// at rest at initial_point_m + (end_s - start_s) velocity_m_s after.
struct WallTranslation {
  Vec3 initial_point_m;
  Vec3 velocity_m_s;
  double start_s = 0.0, end_s = 0.0;
};

/// Sets g.point_m and g.velocity_m_s to the schedule's at time t: the point moved by the time
/// spent moving, clamp(t - start, 0, end - start) (std::clamp's order of tests), times the
/// velocity; the surface velocity is the translation velocity while start <= t < end, else zero.
BIODEM_HD inline void place_translating_wall(WallGeometry& g, const WallTranslation& m, double t) {
  const double since = t - m.start_s, span = m.end_s - m.start_s;
  const double tau = since < 0.0 ? 0.0 : (span < since ? span : since);
  g.point_m = m.initial_point_m + tau * m.velocity_m_s;
  g.velocity_m_s = (t >= m.start_s && t < m.end_s) ? m.velocity_m_s : Vec3{};
}

}  // namespace biodem::walls
