// Case file (SPEC 11; docs/case_file.md): the checks across tables (second pass): something to
// simulate, unused definitions, densities, a complete pair table, the templates in use, insertion
// feasibility, periodic cells, initial overlaps, the time step.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>


#include "case_file/case_parser_detail.hpp"
#include "case_file/derived_quantities.hpp"
#include "contact/time_step.hpp"
#include "core/quat.hpp"
#include "neighbor/skin.hpp"
#include "walls/wall_from_config.hpp"
#include "walls/wall_geometry.hpp"

namespace biodem::case_file::detail {

constexpr double kMaxInsertableSolidFraction = 0.55;  // of the drum volume; random loose packing is ~0.55-0.6
constexpr double kDtWarnFraction = 0.20;              // SPEC 2.5
constexpr double kDtErrorFraction = 0.40;

void CaseParser::check_something_to_simulate() const {
  if (!cfg_.drum && cfg_.particles.empty() && !cfg_.insertion)
    fail("nothing to simulate: give a [drum] with [insertion] and [[population]], or [[particle]] entries");
  if (!cfg_.populations.empty() && !cfg_.insertion)
    fail("[[population]]: populations are only used by [insertion], which is missing");
  if (cfg_.output.frame_every_s && !cfg_.drum)
    fail("[output].frame_every_s: back-lit frames are cross-sections of the drum, and this case has no [drum]");
  for (const auto& [key, value] : {std::pair{"surface_bin_m", cfg_.output.surface_bin_m},
                                   std::pair{"surface_wall_zone_m", cfg_.output.surface_wall_zone_m}}) {
    if (!value) continue;
    if (!cfg_.drum)
      fail(std::string("[output].") + key + ": the free surface is measured in the drum, and this case has no [drum]");
    // (at least a few bins across the bed, and some surface left between the two wall zones)
    const double R = 0.5 * cfg_.drum->diameter_m, limit = std::string(key) == "surface_bin_m" ? 0.2 * R : 0.5 * R;
    if (*value > limit)
      fail(std::string("[output].") + key + " = " + num(*value) + ": at most " + num(limit) + " m (" +
           (std::string(key) == "surface_bin_m" ? "a fifth" : "half") + " of the drum radius)");
  }
  if (cfg_.output.speed_images.value_or(false) && !cfg_.drum)
    fail("[output].speed_images: the speed images are views of the drum from its end, and this case has no [drum]");
  // SPEC 5: the drum's axis is z and y is up; alpha, the free surface, the frames and the speed
  // images are measured so. Gravity along the axis, along x or none would give angles of another
  // frame without a word.
  if (cfg_.drum) {
    const auto& g = cfg_.run.gravity_m_s2;
    if (!(g[0] == 0.0 && g[2] == 0.0 && g[1] < 0.0))
      fail("[run].gravity_m_s2 = [" + num(g[0]) + ", " + num(g[1]) + ", " + num(g[2]) +
           "]: a drum case has y up and its axis along z (SPEC 5); gravity must be [0, -g, 0]");
  }
}

// The outputs are written after whole steps: every max(1, round(interval / dt)) steps. An
// interval under half a step cannot be honoured (sample_hz = 1e6 at dt = 1e-5 s sampled at
// 1e5 Hz, snapshot_every_s = 1e-9 wrote a snapshot at every step); one the rounding moves by
// more than 1 % is said, with the interval the run will use.
void CaseParser::check_output_cadence() {
  const double dt = cfg_.run.dt_s;
  const auto& o = cfg_.output;
  const std::pair<const char*, std::optional<double>> intervals[] = {
      {"sample_hz", 1.0 / o.sample_hz},
      {"snapshot_every_s", o.snapshot_every_s},
      {"checkpoint_every_s", o.checkpoint_every_s},
      {"frame_every_s", o.frame_every_s},
      {"speed_image_every_s", o.speed_image_every_s}};
  for (const auto& [key, interval] : intervals) {
    if (!interval) continue;
    const bool hz = std::string_view(key) == "sample_hz";
    const std::string given = std::string("[output].") + key + " = " + num(hz ? o.sample_hz : *interval);
    if (*interval < 0.5 * dt)
      fail(given + ": " + (hz ? "a sample period" : "an interval") + " of " + num(*interval) +
           " s, under half the time step dt = " + num(dt) + " s (outputs are written after whole steps)");
    const double steps = std::max(1.0, std::round(*interval / dt)), used = steps * dt;
    if (std::abs(used - *interval) > 0.01 * *interval)
      warn(given + ": outputs are written after whole steps, so every " + num(steps) + " steps of dt = " + num(dt) +
           " s: " + (hz ? num(1.0 / used) + " Hz" : num(used) + " s") + " (" +
           num(100.0 * (used - *interval) / *interval, 2) + " % off)");
  }
}

void CaseParser::check_unused() {
  // (SPEC 11's case: the snapshot and checkpoint keys are optional only in explicit scenes; a
  // drum case without them runs, but says what it will not write)
  if (cfg_.drum && cfg_.insertion && !cfg_.output.checkpoint_every_s)
    warn("[output].checkpoint_every_s is not given: no checkpoints (only SIGINT or SIGTERM write one), so a run "
         "killed otherwise cannot be resumed");
  if (cfg_.drum && cfg_.insertion && !cfg_.output.snapshot_every_s)
    warn("[output].snapshot_every_s is not given: snapshots only after the insertion and at the end");
#if BIODEM_HAVE_OPENCV
  const bool speed_images = cfg_.drum && cfg_.output.speed_images.value_or(true);
#else
  const bool speed_images = false;  // (the lean build has none; `run` refuses speed_images = true)
#endif
  if (!speed_images) {
    const char* unused = cfg_.output.speed_image_max_m_s ? "speed_image_max_m_s"
                         : cfg_.output.speed_image_every_s ? "speed_image_every_s"
                         : cfg_.output.speed_image_size_px != config::Output{}.speed_image_size_px ? "speed_image_size_px"
                                                                                                   : nullptr;
    if (unused)
      warn(std::string("[output].") + unused +
           " is not used: no speed images (they need a [drum], speed_images not false and a build with OpenCV)");
  }
  std::set<std::size_t> used;
  for (const auto& p : cfg_.populations) used.insert(p.shape);
  for (const auto& p : cfg_.particles) used.insert(p.shape);
  for (std::size_t s = 0; s < cfg_.shapes.size(); ++s)
    if (!used.count(s)) warn(entry_path("shape", s, cfg_.shapes[s].name) + " is not used");
}

std::set<std::size_t> CaseParser::particle_materials() const {
  std::set<std::size_t> m;
  for (const auto& p : cfg_.populations) m.insert(p.material);
  for (const auto& p : cfg_.particles) m.insert(p.material);
  return m;
}

void CaseParser::check_particle_densities() const {
  for (std::size_t m : particle_materials())
    if (!cfg_.materials[m].density_kg_m3)
      fail(entry_path("material", m, mat_name(m)) +
           " .density_kg_m3: required key is missing (the material is used by particles)");
}

void CaseParser::check_pairs_complete() const {
  std::set<std::pair<std::size_t, std::size_t>> have;
  for (const auto& p : cfg_.pairs) have.insert(std::minmax(p.material_a, p.material_b));
  auto need = [&](std::size_t a, std::size_t b, const std::string& why) {
    if (!have.count(std::minmax(a, b)))
      fail("[[pair]] with materials = [\"" + mat_name(a) + "\", \"" + mat_name(b) + "\"] is missing (" + why +
           ")");
  };
  const auto pm = particle_materials();
  for (auto a = pm.begin(); a != pm.end(); ++a)
    for (auto b = a; b != pm.end(); ++b) need(*a, *b, "particles of these materials can touch");
  std::vector<std::pair<std::size_t, std::string>> wall_materials;
  if (cfg_.drum) {
    wall_materials.emplace_back(cfg_.drum->mantle_material, "the drum mantle");
    if (cfg_.drum->endplate_material) wall_materials.emplace_back(*cfg_.drum->endplate_material, "the drum end plates");
  }
  for (std::size_t i = 0; i < cfg_.walls.size(); ++i) wall_materials.emplace_back(cfg_.walls[i].material, entry_path("wall", i));
  for (std::size_t a : pm)
    for (const auto& [w, what] : wall_materials) need(a, w, "particles of " + mat_name(a) + " can touch " + what);
}

void CaseParser::build_templates() {
  const double s = particle_coarse_grain(cfg_);
  std::set<std::size_t> used;
  for (const auto& p : cfg_.populations) used.insert(p.shape);
  for (const auto& p : cfg_.particles) used.insert(p.shape);
  for (std::size_t i : used) {
    try {
      templates_.emplace(i, shapes::make_template(cfg_.shapes[i], s));
    } catch (const Error& e) {
      fail(entry_path("shape", i, cfg_.shapes[i].name) + ": " + e.what());
    }
  }
}

void CaseParser::check_insertion_feasible() const {
  if (cfg_.insertion && cfg_.insertion->region != config::Insertion::Region::Drum) return check_region_feasible();
  if (!cfg_.insertion || !cfg_.drum) return;
  const auto& d = *cfg_.drum;
  const bool periodic = d.axial_boundary == config::AxialBoundary::Periodic;
  for (const auto& p : cfg_.populations) {
    const auto& t = templates_.at(p.shape);
    const std::string who = "shape " + cfg_.shapes[p.shape].name;
    if (!(2.0 * t.bounding_radius_m < d.diameter_m))
      fail("[drum].diameter_m = " + num(d.diameter_m) + ": too small for " + who + " (bounding diameter " +
           num(2.0 * t.bounding_radius_m) + " m after coarse graining)");
    if (!periodic && !(2.0 * t.max_radius_m < d.width_m))
      fail("[drum].width_m = " + num(d.width_m) + ": too narrow for " + who + " (sphere diameter " +
           num(2.0 * t.max_radius_m) + " m after coarse graining)");
  }
  const double vmean = mean_population_particle_volume_m3(cfg_);
  const std::uint64_t n = implied_particle_count(cfg_);
  const double fraction = static_cast<double>(n) * vmean / drum_volume_m3(d);
  const auto& ins = *cfg_.insertion;
  if (n == 0) fail("[insertion].fill_fraction = " + num(*ins.fill_fraction) + ": implies no particle at all");
  if (fraction > kMaxInsertableSolidFraction) {
    const std::string key = ins.count ? "[insertion].count = " + std::to_string(n)
                                      : "[insertion].fill_fraction = " + num(*ins.fill_fraction) + " (count " +
                                            std::to_string(n) + ")";
    fail(key + ": the particles' solid volume is " + num(100.0 * fraction, 3) +
         " % of the drum volume; at most " + num(100.0 * kMaxInsertableSolidFraction) + " % can be inserted");
  }
}

// Same rules as the drum: every shape fits the region; a packed region cannot take more
// solid than the drum's limit (poured waves are limited by the three-empty-waves rule at run time).
void CaseParser::check_region_feasible() const {
  const auto& ins = *cfg_.insertion;
  const bool box = ins.region == config::Insertion::Region::Box;
  double smallest = 0.0;
  if (box) {
    smallest = kInf;
    for (int a = 0; a < 3; ++a) smallest = std::min(smallest, ins.region_max_m[a] - ins.region_min_m[a]);
  } else {
    smallest = std::min(2.0 * ins.region_radius_m, ins.region_height_m);
  }
  const std::string key = box ? "[insertion].region_max_m" : "[insertion].region_radius_m";
  for (const auto& p : cfg_.populations) {
    const auto& t = templates_.at(p.shape);
    if (!(2.0 * t.bounding_radius_m < smallest))
      fail(key + ": the region (smallest size " + num(smallest) + " m) is too small for shape " +
           cfg_.shapes[p.shape].name + " (bounding diameter " + num(2.0 * t.bounding_radius_m) +
           " m after coarse graining)");
  }
  if (ins.mode == config::Insertion::Mode::Pack) {
    const double volume = box ? (ins.region_max_m[0] - ins.region_min_m[0]) * (ins.region_max_m[1] - ins.region_min_m[1]) *
                                    (ins.region_max_m[2] - ins.region_min_m[2])
                              : std::numbers::pi * ins.region_radius_m * ins.region_radius_m * ins.region_height_m;
    const double fraction = static_cast<double>(*ins.count) * mean_population_particle_volume_m3(cfg_) / volume;
    if (fraction > kMaxInsertableSolidFraction)
      fail("[insertion].count = " + std::to_string(*ins.count) + ": the particles' solid volume is " +
           num(100.0 * fraction, 3) + " % of the region volume; at most " + num(100.0 * kMaxInsertableSolidFraction) +
           " % can be packed in one wave");
  }
}

void CaseParser::check_periodic_cells() const {
  // The cell list needs at least 3 cells across a periodic length, a cell being at least the
  // largest sphere diameter plus the skin (so that no pair is seen twice through the boundary).
  double dmax = 0.0, rmin = kInf;
  for (const auto& [s, t] : templates_) {
    dmax = std::max(dmax, 2.0 * t.max_radius_m);
    rmin = std::min(rmin, t.min_radius_m);
  }
  const double skin = cfg_.run.skin_m.value_or(neighbor::default_skin_m(rmin));  // as resolved_skin_m(), without rebuilding templates
  const double cell = dmax + skin;
  const std::string why = " (largest sphere diameter " + num(dmax) + " m + skin " + num(skin) + " m)";
  if (cfg_.drum && cfg_.drum->axial_boundary == config::AxialBoundary::Periodic && cfg_.drum->width_m < 3.0 * cell)
    fail("[drum].width_m = " + num(cfg_.drum->width_m) + ": a periodic drum must be at least " + num(3.0 * cell) +
         " m wide, 3 x" + why);
  if (cfg_.domain)
    for (int k = 0; k < 3; ++k) {
      const double len = cfg_.domain->max_m[k] - cfg_.domain->min_m[k];
      if (cfg_.domain->periodic[k] && len < 3.0 * cell)
        fail("[domain].max_m: the periodic length along " + std::string(1, "xyz"[k]) + " is " + num(len) +
             " m; it must be at least " + num(3.0 * cell) + " m, 3 x" + why);
    }
}

// Positions along a periodic axis are not wrapped into the cell (the engines wrap only the pair
// distances), so a wall or sink test that depends on the position along that axis would see a
// body that crossed the boundary where it is not: it passed through a floor plate after one
// period. Walls and sinks must not depend on it: planes and below_plane sinks with a normal
// across the axis, infinite cylinders along it, outside_box sinks spanning the cell.
void CaseParser::check_walls_across_periodic_axes() const {
  if (!cfg_.domain) return;
  for (int k = 0; k < 3; ++k) {
    if (!cfg_.domain->periodic[k]) continue;
    const std::string axis(1, "xyz"[k]);
    const std::string why = ": the domain is periodic along " + axis +
                            " ([domain].periodic), where positions are not wrapped into the cell for wall and sink "
                            "tests (a body that crossed the boundary would pass through it)";
    auto along = [&](const config::Vec3d& v) {  // |v_k| / |v|
      const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
      return n > 0.0 ? std::abs(v[k]) / n : 0.0;
    };
    for (std::size_t i = 0; i < cfg_.walls.size(); ++i) {
      const config::Wall& w = cfg_.walls[i];
      const std::string who = entry_path("wall", i);
      switch (w.kind) {
        case config::WallKind::Plane:
          if (along(w.normal) > 1e-9) fail(who + " (plane): its normal must be perpendicular to " + axis + why);
          break;
        case config::WallKind::Cylinder:
          if (w.length_m > 0.0) fail(who + " (finite cylinder): not allowed" + why);
          if (along(w.normal) < 1.0 - 1e-12) fail(who + " (cylinder): its axis must be along " + axis + why);
          break;
        case config::WallKind::Disc:
          fail(who + " (disc): not allowed" + why);
        case config::WallKind::Rectangle:
          fail(who + " (rectangle): not allowed" + why);
      }
    }
    for (std::size_t i = 0; i < cfg_.sinks.size(); ++i) {
      const config::Sink& s = cfg_.sinks[i];
      const std::string who = entry_path("sink", i);
      if (s.kind == config::SinkKind::BelowPlane && along(s.normal) > 1e-9)
        fail(who + " (below_plane): its normal must be perpendicular to " + axis + why);
      if (s.kind == config::SinkKind::OutsideBox &&
          (s.min_m[k] > cfg_.domain->min_m[k] || s.max_m[k] < cfg_.domain->max_m[k]))
        fail(who + " (outside_box): along " + axis + " it must span the periodic cell [" + num(cfg_.domain->min_m[k]) +
             ", " + num(cfg_.domain->max_m[k]) + "]" + why);
    }
  }
}

// An explicit particle whose centre is outside the box bodies must stay in ([run] bounds, or a
// [domain] box along its non-periodic axes) would stop the run as lost at its first step: said
// here, before anything runs.
void CaseParser::check_particles_inside_bounds() const {
  for (std::size_t i = 0; i < cfg_.particles.size(); ++i) {
    const config::Vec3d& x = cfg_.particles[i].position_m;
    for (int k = 0; k < 3; ++k) {
      const std::string axis(1, "xyz"[k]);
      if (cfg_.run.bounds_min_m && cfg_.run.bounds_max_m &&
          (x[k] < (*cfg_.run.bounds_min_m)[k] || x[k] > (*cfg_.run.bounds_max_m)[k]))
        fail(entry_path("particle", i) + ".position_m: " + axis + " = " + num(x[k]) +
             " m is outside the [run] bounds box (bounds_min_m, bounds_max_m)");
      if (!cfg_.run.bounds_min_m && cfg_.domain && !cfg_.domain->periodic[k] &&
          (x[k] < cfg_.domain->min_m[k] || x[k] > cfg_.domain->max_m[k]))
        fail(entry_path("particle", i) + ".position_m: " + axis + " = " + num(x[k]) + " m is outside the [domain] box");
    }
  }
}

void CaseParser::check_initial_overlaps() const {
  if (cfg_.run.allow_initial_overlap || cfg_.particles.empty()) return;
  const std::string hint = " (set [run] allow_initial_overlap = true to allow it)";
  // Spheres in the lab frame. An explicit particle's orientation is relative to the frame its
  // shape was written in (identity shows the shape as written): shapes::body_orientation.
  // Drum walls are not checked here (explicit particles in a drum are unusual, and the drum's
  // placement belongs to the engine); periodic images are not checked either.
  struct S {
    Vec3 c;
    double r;
    std::size_t body;
  };
  std::vector<S> spheres;
  double rmax = 0.0;
  for (std::size_t i = 0; i < cfg_.particles.size(); ++i) {
    const auto& p = cfg_.particles[i];
    const auto& t = templates_.at(p.shape);
    const Quat q = shapes::body_orientation(t, Quat{p.orientation[0], p.orientation[1], p.orientation[2], p.orientation[3]});
    const Vec3 x{p.position_m[0], p.position_m[1], p.position_m[2]};
    for (std::size_t k = 0; k < t.sphere_count(); ++k) {
      spheres.push_back({x + rotate(q, t.offsets_m[k]), t.radii_m[k], i});
      rmax = std::max(rmax, t.radii_m[k]);
    }
  }
  // Walls.
  for (const auto& s : spheres)
    for (std::size_t w = 0; w < cfg_.walls.size(); ++w) {
      const auto& cw = cfg_.walls[w];
      const walls::WallGeometry g = walls::geometry_from_config(cw);
      const walls::WallHit h = walls::wall_hit(g, s.c, s.r);
      const double overlap = s.r - h.gap_m;
      if (h.touching && overlap > 1e-9 * s.r)
        fail(entry_path("particle", s.body) + " overlaps " + entry_path("wall", w) + " by " + num(overlap, 3) +
             " m" + hint);
    }
  // Particle pairs, through a hashed grid of cell size 2 rmax; the first pair in index order
  // is reported so that the message does not depend on hashing.
  const double h = 2.0 * rmax;
  auto cell = [h](double v) { return static_cast<std::int64_t>(std::floor(v / h)); };
  auto key = [](std::int64_t x, std::int64_t y, std::int64_t z) {
    return ((x & 0x1FFFFF) << 42) | ((y & 0x1FFFFF) << 21) | (z & 0x1FFFFF);  // aliasing only costs checks
  };
  std::unordered_map<std::int64_t, std::vector<std::size_t>> grid;
  for (std::size_t i = 0; i < spheres.size(); ++i)
    grid[key(cell(spheres[i].c.x), cell(spheres[i].c.y), cell(spheres[i].c.z))].push_back(i);
  std::size_t best_a = std::numeric_limits<std::size_t>::max(), best_b = 0;
  double best_overlap = 0.0;
  for (std::size_t i = 0; i < spheres.size(); ++i) {
    const S& a = spheres[i];
    if (a.body > best_a) break;
    const std::int64_t cx = cell(a.c.x), cy = cell(a.c.y), cz = cell(a.c.z);
    for (std::int64_t dx = -1; dx <= 1; ++dx)
      for (std::int64_t dy = -1; dy <= 1; ++dy)
        for (std::int64_t dz = -1; dz <= 1; ++dz) {
          auto it = grid.find(key(cx + dx, cy + dy, cz + dz));
          if (it == grid.end()) continue;
          for (std::size_t j : it->second) {
            const S& b = spheres[j];
            if (b.body <= a.body) continue;
            const double overlap = a.r + b.r - norm(a.c - b.c);
            if (overlap <= 1e-9 * std::min(a.r, b.r)) continue;
            if (a.body < best_a || (a.body == best_a && b.body < best_b)) {
              best_a = a.body, best_b = b.body, best_overlap = overlap;
            } else if (a.body == best_a && b.body == best_b) {
              best_overlap = std::max(best_overlap, overlap);
            }
          }
        }
  }
  if (best_a != std::numeric_limits<std::size_t>::max())
    fail(entry_path("particle", best_a) + " overlaps " + entry_path("particle", best_b) + " by " +
         num(best_overlap, 3) + " m" + hint);
}

void CaseParser::check_time_step() {
  double tr_min = kInf;
  std::string who;
  const double dt = cfg_.run.dt_s;
  std::set<std::pair<std::size_t, std::size_t>> types;
  for (const auto& p : cfg_.populations) types.insert({p.material, p.shape});
  for (const auto& p : cfg_.particles) types.insert({p.material, p.shape});
  for (const auto& [m, s] : types) {
    const auto& mat = cfg_.materials[m];
    const double tr =
        contact::rayleigh_time_s(templates_.at(s).min_radius_m, *mat.density_kg_m3, mat.young_pa, mat.poisson);
    if (tr < tr_min) tr_min = tr, who = "material " + mat.name + ", shape " + cfg_.shapes[s].name;
  }
  if (!std::isfinite(tr_min)) return;
  const double f = dt / tr_min;
  const std::string what = "[run].dt_s = " + num(dt) + ": " + num(100.0 * f, 3) + " % of the Rayleigh time T_R = " +
                           num(tr_min, 4) + " s (" + who + ")";
  if (f > kDtErrorFraction) {
    if (!cfg_.run.allow_large_dt)
      fail(what + " (limit 40 %; set [run] allow_large_dt = true to override)");
    warn(what + ": above the 40 % limit, allowed by [run] allow_large_dt = true");
  } else if (f > kDtWarnFraction) {
    warn(what + ": above the recommended 20 %");
  }
}

}  // namespace biodem::case_file::detail
