#include "driver/build_simulation.hpp"

#include "contact/time_step.hpp"
#include "contact/viscous_damping.hpp"
#include "core/error.hpp"
#include "case_file/derived_quantities.hpp"
#include "walls/wall_from_config.hpp"

namespace biodem::driver {
namespace {
Vec3 v3(const config::Vec3d& a) { return {a[0], a[1], a[2]}; }
}  // namespace

contact::PairTable make_pair_table(const config::CaseConfig& c) {
  contact::PairTable t(c.materials.size());
  for (const auto& p : c.pairs) {
    const auto& a = c.materials[p.material_a];
    const auto& b = c.materials[p.material_b];
    contact::PairParams q;
    q.y_eff_pa = 1.0 / (contact::inverse_effective_young_term(a.young_pa, a.poisson) +
                        contact::inverse_effective_young_term(b.young_pa, b.poisson));
    q.g_eff_pa = 1.0 / (contact::inverse_effective_shear_term(a.young_pa, a.poisson) +
                        contact::inverse_effective_shear_term(b.young_pa, b.poisson));
    q.beta = contact::damping_beta(p.restitution);
    q.friction = p.sliding_friction;
    q.rolling_friction = p.rolling_friction;
    q.cohesion_energy_density_j_m3 = p.cohesion_energy_density_j_m3;
    q.defined = true;
    q.tangential_reduce = c.contact.tangential_reduce;
    t.set(p.material_a, p.material_b, q);
  }
  return t;
}

BuiltCase build_simulation(const config::CaseConfig& c) {
  BuiltCase out;
  out.coarse_grain = c.insertion ? c.insertion->coarse_grain : 1.0;
  std::vector<shapes::ClumpTemplate> templates;
  for (const auto& s : c.shapes) templates.push_back(shapes::make_template(s, out.coarse_grain));
  std::vector<double> density;
  for (const auto& m : c.materials) density.push_back(m.density_kg_m3.value_or(0.0));
  out.sim = std::make_unique<sim::Simulation>(templates, density, make_pair_table(c), c.run.dt_s, v3(c.run.gravity_m_s2));
  auto& sim = *out.sim;

  if (c.domain) {
    neighbor::Domain d;
    d.periodic = c.domain->periodic;
    d.lo_m = v3(c.domain->min_m);
    d.hi_m = v3(c.domain->max_m);
    sim.set_domain(d);
  }
  if (c.drum) {
    scenario::DrumGeometry g;
    g.diameter_m = c.drum->diameter_m;
    g.width_m = c.drum->width_m;
    g.rpm = c.drum->rpm;
    g.mantle_material = static_cast<std::uint16_t>(c.drum->mantle_material);
    g.endplate_material = static_cast<std::uint16_t>(c.drum->endplate_material.value_or(0));
    g.periodic_axis = c.drum->axial_boundary == config::AxialBoundary::Periodic;
    scenario::add_drum(sim, g);
    out.drum = g;
  }
  for (const auto& w : c.walls) {
    sim::WallSpec s;
    s.geometry = walls::geometry_from_config(w);
    s.translation_velocity_m_s = v3(w.translation_velocity_m_s);
    s.move_start_s = w.move_start_s;
    s.move_end_s = w.move_end_s;
    s.material = static_cast<std::uint16_t>(w.material);
    sim.add_wall(s);
  }
  for (const auto& k : c.sinks) {
    sim::SinkSpec s;
    s.kind = k.kind == config::SinkKind::BelowPlane ? sim::SinkSpec::Kind::BelowPlane : sim::SinkSpec::Kind::OutsideBox;
    s.point_m = v3(k.point_m);
    s.normal = normalized(v3(k.normal));
    s.min_m = v3(k.min_m);
    s.max_m = v3(k.max_m);
    sim.add_sink(s);
  }
  sim.set_skin(case_file::resolved_skin_m(c));
  sim.set_wall_rolling_lab(c.contact.wall_rolling_reference == config::WallRollingReference::Lab);
  {
    // Where bodies must stay: the drum, or the [run] bounds box of an explicit scene, or else its
    // [domain] box (a body outside it would sit in a clamped edge cell of the neighbour grid).
    sim::LostRegion lr;
    lr.remove = c.run.remove_lost_particles;
    if (c.drum) {
      lr.kind = sim::LostRegion::Kind::Drum;
      lr.radius_m = 0.5 * c.drum->diameter_m;
      lr.z0_m = 0.0;
      lr.z1_m = c.drum->width_m;
      lr.periodic_z = c.drum->axial_boundary == config::AxialBoundary::Periodic;
    } else if (c.run.bounds_min_m) {
      lr.kind = sim::LostRegion::Kind::Box;
      lr.min_m = v3(*c.run.bounds_min_m);
      lr.max_m = v3(*c.run.bounds_max_m);
    } else if (c.domain) {
      lr.kind = sim::LostRegion::Kind::Box;
      lr.min_m = v3(c.domain->min_m);
      lr.max_m = v3(c.domain->max_m);
      for (int k = 0; k < 3; ++k) lr.box_periodic[k] = c.domain->periodic[k];
      lr.box_name = "[domain] box";
    }
    sim.set_lost_region(lr);
  }
  for (const auto& p : c.particles) {
    sim::BodyInit b;
    b.shape = static_cast<std::uint32_t>(p.shape);
    b.material = static_cast<std::uint16_t>(p.material);
    b.position_m = v3(p.position_m);
    b.velocity_m_s = v3(p.velocity_m_s);
    b.angular_velocity_rad_s = v3(p.angular_velocity_rad_s);
    b.orientation = shapes::body_orientation(
        templates[p.shape], Quat{p.orientation[0], p.orientation[1], p.orientation[2], p.orientation[3]});
    sim.add_body(b);
  }
  for (const auto& p : c.populations) {
    out.populations.push_back({static_cast<std::uint32_t>(p.shape), static_cast<std::uint16_t>(p.material)});
    out.population_volume_fraction.push_back(p.volume_fraction);
    out.population_particle_volume_m3.push_back(templates[p.shape].volume_m3);
  }
  return out;
}

}  // namespace biodem::driver
