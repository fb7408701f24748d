// The small scene the checkpoint harness loads into: two shapes (a sphere and a three-sphere
// clump), two materials, a floor and a drum mantle, four bodies. make_seed_checkpoint() writes a
// valid checkpoint of it after a few steps (a seed of the committed corpus: seed_v6_*).
#pragma once
#include <string>

#include "contact/pair_table.hpp"
#include "checkpoint/checkpoint.hpp"
#include "shapes/clump_template.hpp"
#include "sim/simulation.hpp"

namespace biodem::fuzz {

inline sim::Simulation make_scene() {
  config::Shape sphere;
  sphere.name = "sphere";
  sphere.kind = config::ShapeKind::Sphere;
  sphere.diameter_m = 2e-3;
  config::Shape clump;
  clump.name = "clump";
  clump.kind = config::ShapeKind::Clump;
  clump.spheres = {{{-1e-3, 0, 0}, 0.8e-3}, {{0, 0, 0}, 0.8e-3}, {{1e-3, 0, 0}, 0.8e-3}};
  contact::PairParams p;
  p.y_eff_pa = 5e6;
  p.g_eff_pa = 2e6;
  p.beta = -0.5;
  p.friction = 0.5;
  p.rolling_friction = 0.1;
  p.cohesion_energy_density_j_m3 = 1e4;
  p.defined = true;
  contact::PairTable t(2);
  t.set(0, 0, p);
  t.set(0, 1, p);
  sim::Simulation s({shapes::make_template(sphere, 1.0), shapes::make_template(clump, 1.0)}, {1000.0, 0.0}, t, 1e-5,
                    {0, -9.81, 0});
  sim::WallSpec floor;
  floor.geometry.kind = walls::Kind::Plane;
  floor.geometry.point_m = {0, -10e-3, 0};
  floor.geometry.normal = {0, 1, 0};
  floor.material = 1;
  s.add_wall(floor);
  sim::WallSpec drum;
  drum.geometry.kind = walls::Kind::Cylinder;
  drum.geometry.normal = {0, 0, 1};
  drum.geometry.radius_m = 12e-3;
  drum.geometry.angular_velocity_rad_s = 1.0;
  drum.material = 1;
  s.add_wall(drum);
  // The skin is set (d/4 of the smallest sphere): the bodies stand 0.2 mm apart, which the list
  // must hold; the default (d/8 = 0.2 mm) would leave them on the edge of the cut-off.
  s.set_skin(0.4e-3);
  for (int k = 0; k < 4; ++k) {
    sim::BodyInit b;
    b.shape = static_cast<std::uint32_t>(k % 2);
    // Resting on the floor, 0.2 mm apart: list entries and wall contacts exist.
    b.position_m = {-5e-3 + 3e-3 * k, -10e-3 + (k % 2 ? 0.79e-3 : 0.99e-3), 0};
    s.add_body(b);
  }
  return s;
}

inline void make_seed_checkpoint(const std::string& path) {
  sim::Simulation s = make_scene();
  s.run_steps(50);
  checkpoint::RunProgress rp;
  rp.pvd_spheres = {{0.0, "spheres_0.vtu"}};
  // Version 5: taken between two insertion waves, so that the insertion state (with the
  // generator's text) is in the payload too.
  rp.last_sample_step = 50;
  rp.last_snapshot_step = 0;
  rp.insertion.active = true;
  rp.insertion.placed = 4;
  rp.insertion.waves = 1;
  rp.insertion.fall_step = 50;
  rp.insertion.rng.seed(1);
  // Version 6: the engine that wrote it and the GPU engine's family of contact sums.
  rp.engine = "gpu-emulated";
  rp.contact_sums = "fixed";
  checkpoint::save_checkpoint(path, s, rp);
}

}  // namespace biodem::fuzz
