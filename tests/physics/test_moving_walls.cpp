// Walls that move and end (issue 9): prescribed translation, finite rectangles, the open finite
// cylinder, and the sparse wall contact table (any number of walls). Material: the glass beads
// of the reference case (R = 0.5 mm, rho = 2550, E = 5e6 Pa, nu = 0.22), the wall with the same
// E and nu, e = 0.87, reference dt 1.5e-5 s.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "physics_support.hpp"

using namespace biodem;
using namespace biodem::phys;

namespace {

constexpr double kR = 0.5e-3, kG = 9.81;
const Material kBead{5e6, 0.22, 2550.0};

SimSetup bead_setup(double mu_pp, double mu_pw) {
  SimSetup su;
  su.particle = kBead;
  su.wall = kBead;
  su.particle_wall = {0.87, mu_pw, 0.0, 0.0};
  su.particle_particle = {0.87, mu_pp, 0.0, 0.0};
  su.templates = {sphere_template(kR)};
  su.dt_s = 1.5e-5;
  su.gravity_m_s2 = {0, -kG, 0};
  return su;
}

sim::WallSpec rectangle_wall(const Vec3& centre, const Vec3& normal, const Vec3& u, double a, double b) {
  sim::WallSpec w;
  w.geometry.kind = walls::Kind::Rectangle;
  w.geometry.point_m = centre;
  w.geometry.normal = normalized(normal);
  w.geometry.edge_u = normalized(u);
  w.geometry.half_u_m = 0.5 * a;
  w.geometry.half_v_m = 0.5 * b;
  w.material = kWall;
  return w;
}

double static_overlap_m() {
  return hertz_static_overlap_m(sphere_mass_kg(kR, kBead.density_kg_m3) * kG, kR, effective_young_pa(kBead, kBead));
}

}  // namespace

// A bead resting on a 20 x 20 mm rectangular plate; the plate is lifted at 50 mm/s from
// t = 0.1 s to 0.2 s (5 mm). While the plate moves, the bead moves with it (mean vertical
// velocity over the second half of the lift within 1 % of 50 mm/s: the start is an impact at
// 50 mm/s, damped within a few ms); after the lift it rests on the plate again at the Hertz static
// overlap (within 2 % of delta = 0.3 um, i.e. its height is the plate's 5 mm + R - delta to 6e-9 m).
// A sign error lowers the bead, a factor 2 lifts it 10 mm, an unmoved contact point lets it fall.
TEST(MovingWalls, BeadRidesOnALiftedPlate) {
  const ScopedThreads one_thread(1);
  const SimSetup su = bead_setup(0.5, 0.5);
  sim::Simulation s = make_simulation(su);
  sim::WallSpec plate = rectangle_wall({0, 0, 0}, {0, 1, 0}, {1, 0, 0}, 0.02, 0.02);
  const double v_lift = 0.05, t0 = 0.1, t1 = 0.2;
  plate.translation_velocity_m_s = {0, v_lift, 0};
  plate.move_start_s = t0;
  plate.move_end_s = t1;
  s.add_wall(plate);
  add_particle(s, 0, {0.001, kR, 0.002});
  std::vector<double> vy;
  while (s.time_s() < 0.35) {
    s.step();
    if (s.time_s() > 0.5 * (t0 + t1) && s.time_s() < t1 - 1e-3) vy.push_back(s.bodies().velocity_m_s[0].y);
  }
  double mean = 0.0;
  for (double v : vy) mean += v / static_cast<double>(vy.size());
  report("bead velocity while the plate rises [m/s]", mean, v_lift);
  EXPECT_NEAR(mean / v_lift, 1.0, 0.01);
  EXPECT_NEAR(s.walls()[0].geometry.point_m.y, v_lift * (t1 - t0), 1e-12);
  EXPECT_EQ(norm(s.walls()[0].geometry.velocity_m_s), 0.0);  // at rest after move_end_s
  const double overlap = v_lift * (t1 - t0) + kR - s.bodies().position_m[0].y;
  report("overlap on the lifted plate [m]", overlap, static_overlap_m());
  EXPECT_NEAR(overlap / static_overlap_m(), 1.0, 0.02);
}

// 99 planes far below (y = -1 m ... -1.98 m) and, last, the plane y = 0 the bead rests on: the
// bead stays at the Hertz static overlap (within 1 %; before the sparse table, walls beyond the
// 64th were ignored and the bead fell through), and the contact table holds one candidate, not
// 100 (memory per candidate, not per sphere and wall).
TEST(MovingWalls, BeadRestsOnTheLastOfAHundredWalls) {
  const ScopedThreads one_thread(1);
  sim::Simulation s = make_simulation(bead_setup(0.5, 0.5));
  for (int k = 0; k < 99; ++k) s.add_wall(plane_wall({0, -1.0 - 0.01 * k, 0}, {0, 1, 0}));
  s.add_wall(plane_wall({0, 0, 0}, {0, 1, 0}));
  add_particle(s, 0, {0, kR, 0});
  s.run_steps(static_cast<std::uint64_t>(0.1 / 1.5e-5));
  const double overlap = kR - s.bodies().position_m[0].y;
  report("overlap on wall 100 of 100 [m]", overlap, static_overlap_m());
  EXPECT_NEAR(overlap / static_overlap_m(), 1.0, 0.01);
  ASSERT_EQ(s.wall_contacts().wall.size(), 1u);
  EXPECT_EQ(s.wall_contacts().wall[0], 99u);
  EXPECT_EQ(s.wall_contacts().touching[0], 1);
}

// A column of 32 frictionless beads inside an open tube (radius 3 mm, 30 mm long, axis +y,
// standing on a plate at y = 0): while the tube stands, every bead stays inside it (centre within
// R_tube - R + 5 % of R: the beads are soft, E = 5 MPa, and hit the tube at ~0.1 m/s, a Hertz
// impact overlap of ~10 um); the tube is lifted at 0.2 m/s by 40 mm; afterwards no
// bead centre is inside the tube, the column has collapsed (some bead beyond the tube radius) and
// every bead lies on the plate (no bead above 3 diameters).
TEST(MovingWalls, LiftedCylinderLeavesNoParticleInside) {
  const ScopedThreads one_thread(1);
  sim::Simulation s = make_simulation(bead_setup(0.0, 0.3));
  const double r_tube = 3e-3, l_tube = 0.03;
  s.add_wall(rectangle_wall({0, 0, 0}, {0, 1, 0}, {0, 0, 1}, 0.1, 0.1));
  sim::WallSpec tube;
  tube.geometry.kind = walls::Kind::Cylinder;
  tube.geometry.point_m = {0, 0, 0};
  tube.geometry.normal = {0, 1, 0};
  tube.geometry.radius_m = r_tube;
  tube.geometry.length_m = l_tube;
  tube.material = kWall;
  tube.translation_velocity_m_s = {0, 0.2, 0};
  tube.move_start_s = 0.1;
  tube.move_end_s = 0.3;
  s.add_wall(tube);
  for (int layer = 0; layer < 8; ++layer)
    for (int q = 0; q < 4; ++q) {
      const double a = 0.5 * std::numbers::pi * q + 0.25 * layer;
      add_particle(s, 0, {1.4e-3 * std::cos(a), kR + 1.1e-3 * layer, 1.4e-3 * std::sin(a)});
    }
  auto rho = [&](std::size_t b) {
    const Vec3 x = s.bodies().position_m[b];
    return std::hypot(x.x, x.z);
  };
  double rho_max_standing = 0.0;
  while (s.time_s() < 0.1) {
    s.step();
    for (std::size_t b = 0; b < s.bodies().size(); ++b) rho_max_standing = std::max(rho_max_standing, rho(b));
  }
  report("largest bead centre radius while the tube stands [m]", rho_max_standing, r_tube - kR);
  EXPECT_LT(rho_max_standing, r_tube - kR + 0.05 * kR);
  while (s.time_s() < 0.5) s.step();
  const double bottom = s.walls()[1].geometry.point_m.y;
  EXPECT_NEAR(bottom, 0.04, 1e-12);
  double rho_max = 0.0, y_max = 0.0;
  int inside = 0;
  for (std::size_t b = 0; b < s.bodies().size(); ++b) {
    const double y = s.bodies().position_m[b].y;
    if (rho(b) < r_tube && y >= bottom && y <= bottom + l_tube) ++inside;
    rho_max = std::max(rho_max, rho(b));
    y_max = std::max(y_max, y);
  }
  std::printf("[measured] beads inside the lifted tube: %d; largest radius %.3g m; highest bead %.3g m\n", inside,
              rho_max, y_max);
  EXPECT_EQ(inside, 0);
  EXPECT_GT(rho_max, r_tube);
  EXPECT_LT(y_max, 6.0 * kR);
}
