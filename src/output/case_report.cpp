#include "output/case_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <utility>
#include <vector>

#include "case_file/derived_quantities.hpp"
#include "config/steps.hpp"
#include "contact/time_step.hpp"
#include "shapes/clump_template.hpp"

namespace biodem::output {
namespace {

using namespace case_file;

std::string num(double v, int digits = 4) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

// The run's own rounding (config/steps.hpp): before, ceil here and round in the run gave phase
// lengths one step apart.
std::string steps(double seconds, double dt) { return std::to_string(config::steps_for(seconds, dt)); }

std::string vec(const config::Vec3d& v) {
  std::string s("[");  // appended piecewise: "[" + std::string trips a GCC 12 -Wrestrict false positive
  s += num(v[0]);
  s += ", ";
  s += num(v[1]);
  s += ", ";
  s += num(v[2]);
  s += "]";
  return s;
}

double gravity_norm(const config::CaseConfig& c) {
  const auto& g = c.run.gravity_m_s2;
  return std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
}

std::string phase_line(const config::CaseConfig& c, const config::Phase& p) {
  const double dt = c.run.dt_s;
  std::ostringstream os;
  os << "  " << p.name << ": ";
  const double rpm = c.drum ? c.drum->rpm : 0.0;
  if (p.until_mean_kinetic_energy_j) {
    os << "until the mean " << (p.translational_criterion ? "translational " : "") << "kinetic energy per body stays below " << num(*p.until_mean_kinetic_energy_j)
       << " J for " << num(p.settle_hold_s) << " s (after at least " << num(p.min_duration_s) << " s, at most "
       << num(p.max_duration_s.value_or(p.duration_s)) << " s = "
       << steps(p.max_duration_s.value_or(p.duration_s), dt) << " steps)";
  } else if (p.move_wall && p.move_by_fill_height) {
    const double v = std::sqrt(p.move_velocity_m_s[0] * p.move_velocity_m_s[0] +
                               p.move_velocity_m_s[1] * p.move_velocity_m_s[1] +
                               p.move_velocity_m_s[2] * p.move_velocity_m_s[2]);
    os << "wall #" << *p.move_wall + 1 << " lifted at " << num(v) << " m/s by the settled fill's height + "
       << num(p.move_margin_m) << " m (at most " << num(p.duration_s * v) << " m = " << num(p.duration_s)
       << " s = " << steps(p.duration_s, dt) << " steps)";
  } else {
    switch (p.length) {
      case config::PhaseLength::Steps:
        os << p.steps << " steps = " << num(static_cast<double>(p.steps) * dt) << " s";
        if (p.rotate && rpm != 0.0)
          os << " = " << num(static_cast<double>(p.steps) * dt * std::abs(rpm) / 60.0) << " revolutions";
        break;
      case config::PhaseLength::Duration:
        os << num(p.duration_s) << " s = " << steps(p.duration_s, dt) << " steps";
        if (p.rotate && rpm != 0.0) os << " = " << num(p.duration_s * std::abs(rpm) / 60.0) << " revolutions";
        break;
      case config::PhaseLength::Revolutions: {
        const double t = p.revolutions * 60.0 / std::abs(rpm);
        os << num(p.revolutions) << " revolutions = " << num(t) << " s = " << steps(t, dt) << " steps";
        break;
      }
    }
  }
  if (c.drum) os << (p.rotate ? ", drum rotating" : ", drum at rest");  // (a scene without a drum: nothing turns)
  os << "\n";
  return os.str();
}

}  // namespace

std::string describe_case(const config::CaseConfig& c) {
  const auto templates = used_templates(c);
  const auto types = particle_types(c);
  const double cg = particle_coarse_grain(c);
  const double dt = c.run.dt_s;
  std::ostringstream os;

  os << "case: " << (c.source_path.empty() ? "(in memory)" : c.source_path) << "\n";
  os << "run: dt = " << num(dt) << " s, seed = " << c.run.seed << ", gravity = " << vec(c.run.gravity_m_s2)
     << " m/s^2, skin = " << num(resolved_skin_m(c)) << " m" << (c.run.skin_m ? "" : " (default: an eighth of the smallest sphere diameter)");
  if (c.run.allow_large_dt) os << ", allow_large_dt";
  if (c.run.allow_initial_overlap) os << ", allow_initial_overlap";
  os << "\n";
  os << "contact: wall_rolling_reference = "
     << (c.contact.wall_rolling_reference == config::WallRollingReference::Lab
             ? "lab (EPSD2 at walls with the particle's own spin, as LIGGGHTS 3.8.0)"
             : "wall (EPSD2 at walls with the spin relative to the wall)")
     << "\n";
  os << "contact: tangential_reduce = "
     << (c.contact.tangential_reduce
             ? "true (friction and rolling limits from |Hertz + damping - cohesion|)"
             : "false (friction and rolling limits from |Hertz + damping|, cohesion kept out, as LIGGGHTS 3.8.0)")
     << "\n";

  os << "materials:\n";
  for (const auto& m : c.materials) {
    os << "  " << m.name << ": ";
    if (m.density_kg_m3) os << "density " << num(*m.density_kg_m3) << " kg/m^3, ";
    os << "Young " << num(m.young_pa) << " Pa, Poisson " << num(m.poisson) << ", shear modulus "
       << num(contact::shear_modulus_pa(m.young_pa, m.poisson)) << " Pa\n";
  }
  os << "pairs:\n";
  for (const auto& p : c.pairs)
    os << "  " << c.materials[p.material_a].name << "/" << c.materials[p.material_b].name << ": restitution "
       << num(p.restitution) << ", sliding friction " << num(p.sliding_friction) << ", rolling friction "
       << num(p.rolling_friction) << ", cohesion energy density " << num(p.cohesion_energy_density_j_m3)
       << " J/m^3\n";

  os << "shapes (lengths after coarse graining x" << num(cg) << "):\n";
  for (std::size_t s = 0; s < c.shapes.size(); ++s) {
    const auto& sh = c.shapes[s];
    os << "  " << sh.name << ": ";
    const auto it = templates.find(s);
    if (it == templates.end()) {
      os << "not used\n";
      continue;
    }
    const auto& t = it->second;
    switch (sh.kind) {
      case config::ShapeKind::Sphere:
        // (n_spb and the length as for a needle: one sphere, as long as its diameter)
        os << "sphere, diameter " << num(2.0 * t.max_radius_m) << " m (n_spb = 1, clump length "
           << num(2.0 * t.max_radius_m) << " m)";
        break;
      case config::ShapeKind::Needle: {
        const auto g = shapes::needle_geometry(sh.d50_m * cg, sh.aspect_ratio, sh.overlap_factor);
        os << "needle, n_spb = " << g.n_spheres << " spheres of diameter " << num(g.sphere_diameter_m)
           << " m, clump length " << num(g.length_m) << " m (aspect ratio " << num(sh.aspect_ratio)
           << ", overlap factor " << num(sh.overlap_factor) << ")";
        break;
      }
      case config::ShapeKind::Clump: {
        // Its length: the largest distance between two points of its spheres.
        double length = 2.0 * t.max_radius_m;
        for (std::size_t a = 0; a < t.sphere_count(); ++a)
          for (std::size_t b = a + 1; b < t.sphere_count(); ++b)
            length = std::max(length, norm(t.offsets_m[a] - t.offsets_m[b]) + t.radii_m[a] + t.radii_m[b]);
        os << "clump, n_spb = " << t.sphere_count() << " spheres, diameters " << num(2.0 * t.min_radius_m);
        if (t.max_radius_m > t.min_radius_m) os << " to " << num(2.0 * t.max_radius_m);
        os << " m, clump length " << num(length) << " m";
        break;
      }
    }
    os << "\n    volume " << num(t.volume_m3) << " m^3, d_eq " << num(t.equivalent_diameter_m())
       << " m, bounding diameter " << num(2.0 * t.bounding_radius_m) << " m\n";
    for (const auto& [m, s2] : types) {
      if (s2 != s) continue;
      const auto& mat = c.materials[m];
      if (!mat.density_kg_m3) continue;
      const double rho = *mat.density_kg_m3;
      const Vec3 i = rho * t.principal_inertia_per_density_m5;
      os << "    as " << mat.name << ": mass " << num(rho * t.volume_m3) << " kg, principal moments of inertia ["
         << num(i.x) << ", " << num(i.y) << ", " << num(i.z) << "] kg m^2\n";
    }
    // The particle as measured (SPEC 8's table), before coarse graining: lengths / cg, volume / cg^3.
    if (cg != 1.0) {
      os << "    before coarse graining: ";
      if (sh.kind == config::ShapeKind::Needle)
        os << "clump length " << num(shapes::needle_geometry(sh.d50_m, sh.aspect_ratio, sh.overlap_factor).length_m) << " m, ";
      os << "volume " << num(t.volume_m3 / (cg * cg * cg)) << " m^3, d_eq " << num(t.equivalent_diameter_m() / cg) << " m\n";
    }
  }

  // Time-step scales (SPEC 2.5). Impact speed: free fall over the drum diameter for a drum,
  // else the largest initial particle speed, else 1 m/s.
  double v_impact = 1.0;
  std::string v_why = "1 m/s (no drum, particles start at rest)";
  const double g = gravity_norm(c);
  if (c.drum && g > 0.0) {
    v_impact = std::sqrt(2.0 * g * c.drum->diameter_m);
    v_why = "sqrt(2 g D) = " + num(v_impact) + " m/s (free fall over the drum diameter)";
  } else {
    double vmax = 0.0;
    for (const auto& p : c.particles)
      vmax = std::max(vmax, std::sqrt(p.velocity_m_s[0] * p.velocity_m_s[0] + p.velocity_m_s[1] * p.velocity_m_s[1] +
                                      p.velocity_m_s[2] * p.velocity_m_s[2]));
    if (vmax > 0.0) {
      v_impact = vmax;
      v_why = num(v_impact) + " m/s (largest initial particle speed)";
    }
  }
  const double tr_min = smallest_rayleigh_time_s(c);
  os << "time step: dt = " << num(dt) << " s";
  if (std::isfinite(tr_min))
    os << " = " << num(100.0 * dt / tr_min, 3) << " % of the smallest Rayleigh time " << num(tr_min)
       << " s (warning above 20 %, refused above 40 %)";
  os << "\n  impact speed for the Hertz contact time: " << v_why << "\n";
  for (const auto& [m, s] : types) {
    const auto& mat = c.materials[m];
    const auto& t = templates.at(s);
    if (!mat.density_kg_m3) continue;
    const double rho = *mat.density_kg_m3;
    const double r = t.min_radius_m;
    const double tr = contact::rayleigh_time_s(r, rho, mat.young_pa, mat.poisson);
    // Same-type particle pair: m* = m/2, R* = r/2 (sphere radius; the mass is the whole clump's).
    const double mass = rho * t.volume_m3;
    const double y_pp = 1.0 / (2.0 * contact::inverse_effective_young_term(mat.young_pa, mat.poisson));
    const double tc = contact::hertz_contact_time_s(0.5 * mass, 0.5 * r, y_pp, v_impact);
    os << "  " << mat.name << " / " << c.shapes[s].name << ": Rayleigh time " << num(tr) << " s (sphere radius "
       << num(r) << " m), dt = " << num(100.0 * dt / tr, 3) << " % of it; Hertz contact time " << num(tc)
       << " s = " << num(tc / dt, 3) << " steps\n";
  }

  if (c.insertion) {
    const auto& ins = *c.insertion;
    const std::uint64_t n = implied_particle_count(c);
    const double vmean = mean_population_particle_volume_m3(c);
    os << "insertion: ";
    if (ins.count)
      os << "count = " << *ins.count;
    else if (ins.fill_fraction)
      os << "fill fraction " << num(*ins.fill_fraction) << " with bulk solid fraction "
         << num(ins.bulk_solid_fraction) << " -> count = " << n;
    os << ", coarse grain x" << num(cg) << ", mean particle volume " << num(vmean) << " m^3, at most "
       << ins.max_attempts_per_particle << " attempts per particle";
    if (ins.wave_fall_s) os << ", waves every " << num(*ins.wave_fall_s) << " s";
    os << "\n";
    for (const auto& p : c.populations)
      os << "  population " << c.shapes[p.shape].name << " / " << c.materials[p.material].name
         << ": volume fraction " << num(p.volume_fraction) << "\n";
    if (c.drum) {
      const auto& d = *c.drum;
      const double vd = drum_volume_m3(d);
      double deq_min = std::numeric_limits<double>::infinity(), deq_max = 0.0;
      for (const auto& p : c.populations) {
        const double de = templates.at(p.shape).equivalent_diameter_m();
        deq_min = std::min(deq_min, de);
        deq_max = std::max(deq_max, de);
      }
      os << "drum: diameter " << num(d.diameter_m) << " m, width " << num(d.width_m) << " m, volume " << num(vd)
         << " m^3, " << num(d.rpm) << " rpm, mantle " << c.materials[d.mantle_material].name << ", "
         << (d.axial_boundary == config::AxialBoundary::Periodic
                 ? std::string("periodic along the axis")
                 : "end plates " + c.materials[*d.endplate_material].name)
         << "\n";
      if (deq_max > 0.0) {
        os << "  particles across the width (width / d_eq): " << num(d.width_m / deq_max, 3);
        if (deq_min < deq_max) os << " to " << num(d.width_m / deq_min, 3);
        os << "\n";
      }
      const double solid = static_cast<double>(n) * vmean / vd;
      os << "  solid volume " << num(static_cast<double>(n) * vmean) << " m^3 = " << num(100.0 * solid, 3)
         << " % of the drum volume";
      // The fill fraction (bed bulk volume / drum volume) a count implies, at the bulk solid
      // fraction [insertion] assumes (SPEC 11: check prints the count for a fill fraction, and
      // here the converse).
      if (ins.count) {
        os << "; a fill fraction of " << num(100.0 * solid / ins.bulk_solid_fraction, 3) << " % at bulk solid fraction "
           << num(ins.bulk_solid_fraction) << " ([insertion].fill_fraction = " << num(solid / ins.bulk_solid_fraction, 3)
           << " gives about this count)";
        // 0.6 is a random packing of spheres; elongated particles pack looser (the raw needles'
        // poured bed in the bulk-density test: solid fraction 0.45, docs/calibration.md), so a
        // needle bed of this count fills more of the drum than the figure above says.
        const bool elongated = std::any_of(c.populations.begin(), c.populations.end(), [&](const auto& p) {
          return c.shapes[p.shape].kind != config::ShapeKind::Sphere;
        });
        if (elongated)
          os << "; not spheres: at a bulk solid fraction of 0.45 (poured raw needles) the fill fraction is "
             << num(100.0 * solid / 0.45, 3) << " %";
      }
      os << "\n";
      if (d.rpm != 0.0) os << "  one revolution: " << num(60.0 / std::abs(d.rpm)) << " s\n";
    }
  }
  if (!c.walls.empty()) os << "walls:\n";
  for (std::size_t i = 0; i < c.walls.size(); ++i) {
    const auto& w = c.walls[i];
    os << "  #" << i + 1 << " "
       << (w.kind == config::WallKind::Plane       ? "plane"
           : w.kind == config::WallKind::Disc      ? "disc"
           : w.kind == config::WallKind::Rectangle ? "rectangle"
                                                   : "cylinder")
       << ", " << c.materials[w.material].name << ", point " << vec(w.point_m) << " m, "
       << (w.kind == config::WallKind::Cylinder ? "axis " : "normal ") << vec(w.normal);
    if (w.kind == config::WallKind::Disc || w.kind == config::WallKind::Cylinder)
      os << ", radius " << num(w.radius_m) << " m";
    if (w.kind == config::WallKind::Rectangle)
      os << ", u " << vec(w.u) << ", size " << num(w.size_m[0]) << " x " << num(w.size_m[1]) << " m";
    if (w.kind == config::WallKind::Cylinder)
      os << ", length " << (w.length_m > 0.0 ? num(w.length_m) + " m" : std::string("infinite"));
    if (w.angular_velocity_rad_s != 0.0) os << ", turning at " << num(w.angular_velocity_rad_s) << " rad/s";
    if (w.move_end_s > w.move_start_s)
      os << ", moving at " << vec(w.translation_velocity_m_s) << " m/s from " << num(w.move_start_s) << " to "
         << num(w.move_end_s) << " s";
    os << "\n";
  }
  for (std::size_t i = 0; i < c.sinks.size(); ++i) {
    const auto& k = c.sinks[i];
    os << "sink #" << i + 1 << ": removes bodies "
       << (k.kind == config::SinkKind::BelowPlane ? "below the plane through " + vec(k.point_m) + " m, normal " + vec(k.normal)
                                                  : "outside the box " + vec(k.min_m) + " .. " + vec(k.max_m) + " m")
       << "\n";
  }
  if (!c.particles.empty()) {
    os << "explicit particles: " << c.particles.size() << "\n";
    for (const auto& [m, s] : types) {
      std::size_t n = 0;
      for (const auto& p : c.particles) n += p.material == m && p.shape == s;
      if (n > 0) os << "  " << n << " x " << c.shapes[s].name << " / " << c.materials[m].name << "\n";
    }
  }
  if (c.domain)
    os << "domain: " << vec(c.domain->min_m) << " to " << vec(c.domain->max_m) << " m, periodic ["
       << c.domain->periodic[0] << ", " << c.domain->periodic[1] << ", " << c.domain->periodic[2] << "]\n";

  os << "phases:\n";
  for (const auto& p : c.phases) os << phase_line(c, p);

  const auto& o = c.output;
  os << "output: sample " << num(o.sample_hz) << " Hz";
  os << ", snapshots " << (o.snapshot_every_s ? "every " + num(*o.snapshot_every_s) + " s" : std::string("final only"));
  os << ", checkpoints " << (o.checkpoint_every_s ? "every " + num(*o.checkpoint_every_s) + " s" : std::string("none"));
  os << ", trace " << (o.trace ? "on" : "off");
  if (o.frame_every_s) os << ", frames every " << num(*o.frame_every_s) << " s at " << o.frame_size_px << " px";
  if (c.drum)  // (the profile of surface_r2 and surface_angle_deg, on the frames' raster)
    os << ", free surface in bins of "
       << (o.surface_bin_m ? num(*o.surface_bin_m) + " m" : "one pixel column of the " + std::to_string(o.frame_size_px) + " px raster")
       << ", wall zone " << (o.surface_wall_zone_m ? num(*o.surface_wall_zone_m) + " m" : std::string("5 % of the drum radius"));
  if (c.drum) {
#if BIODEM_HAVE_OPENCV
    if (o.speed_images.value_or(true))
      os << ", speed images "
         << (o.speed_image_every_s ? "every " + num(*o.speed_image_every_s) + " s" : std::string("at each snapshot"))
         << " (" << o.speed_image_size_px << " px, colour scale 0 to "
         << num(case_file::speed_image_scale_m_s(c)) << " m/s)";
    else
      os << ", speed images off";
#else
    os << ", speed images not built (no OpenCV)";
#endif
  }
  os << "\n";
  return os.str();
}

}  // namespace biodem::output
