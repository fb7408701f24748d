// Case file (SPEC 11; docs/case_file.md): the bulk tests: [heap], [bulk_density], [shear_box]
// (issue 9).
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <string>
#include <vector>


#include "case_file/case_parser_detail.hpp"
#include "config/steps.hpp"
#include "case_file/derived_quantities.hpp"

namespace biodem::case_file::detail {

const char* CaseParser::bulk_block() const {
  for (const char* b : {"heap", "bulk_density", "shear_box"})
    if (single(b)) return b;
  return nullptr;
}

// Expands [heap], [bulk_density] or [shear_box] into walls, a sink, the insertion region and
// the phases. y is up; gravity must point along -y. Default dimensions: docs/calibration.md.
void CaseParser::parse_bulk_test() {
  const char* block = bulk_block();
  if (!block) return;
  for (const char* other : {"heap", "bulk_density", "shear_box"})
    if (other != std::string_view(block) && single(other))
      fail(std::string("[") + other + "]: a case holds one bulk test (also given: [" + block + "])");
  const std::string path = std::string("[") + block + "]";
  if (cfg_.drum) fail(path + ": a bulk test has no [drum]");
  if (!cfg_.insertion) fail("[insertion]: required by " + path + " (count of the particles to pour)");
  if (!cfg_.insertion->count) fail("[insertion].count: required by " + path);
  const auto& g = cfg_.run.gravity_m_s2;
  if (!(g[0] == 0.0 && g[2] == 0.0 && g[1] < 0.0))
    fail("[run].gravity_m_s2: the bulk tests stand on a horizontal plate with y up; gravity must be [0, -g, 0]");
  config::BulkTest b;
  const std::vector<std::string_view> rest_keys = {"rest_fraction", "rest_hold_s", "max_fill_s", "max_rest_s"};
  // with_rest: the test has a rest phase after its fill (heap, shear box; not bulk density).
  auto read_rest = [&](const Reader& r, bool with_rest) {
    b.rest_fraction = r.real_or("rest_fraction", b.rest_fraction, kPositive);
    b.rest_hold_s = r.real_or("rest_hold_s", b.rest_hold_s, kPositive);
    b.max_fill_s = r.real_or("max_fill_s", b.max_fill_s, kPositive);
    // (bulk density has no rest phase after its fill: a max_rest_s there would do nothing)
    if (!with_rest && r.has("max_rest_s"))
      r.fail("max_rest_s", "[bulk_density] has no rest phase after its fill (its cap is max_fill_s)");
    b.max_rest_s = r.real_or("max_rest_s", b.max_rest_s, kPositive);
    // The rest criterion holds for rest_hold_s within each phase's cap, counted in steps as the
    // run counts them: a longer hold is never met.
    const double dt = cfg_.run.dt_s;
    const std::uint64_t hold = std::max<std::uint64_t>(1, config::steps_for(b.rest_hold_s, dt));
    for (const char* cap : {"max_fill_s", "max_rest_s"}) {
      const bool fill = std::string(cap) == "max_fill_s";
      if (!fill && !with_rest) continue;
      const double cap_s = fill ? b.max_fill_s : b.max_rest_s;
      if (hold <= config::steps_for(cap_s, dt)) continue;
      if (r.has("rest_hold_s"))
        r.fail("rest_hold_s", "exceeds " + std::string(cap) + " = " + num(cap_s) + " s: the rest criterion could never be met");
      r.fail(cap, "is shorter than rest_hold_s = " + num(b.rest_hold_s) + " s (its default): the rest criterion could never be met");
    }
  };
  auto& ins = *cfg_.insertion;
  auto wall = [&](config::WallKind k, std::size_t mat, config::Vec3d p, config::Vec3d n) {
    config::Wall w;
    w.kind = k;
    w.material = mat;
    w.point_m = p;
    w.normal = n;
    return w;
  };
  auto rect = [&](std::size_t mat, config::Vec3d centre, config::Vec3d n, config::Vec3d u, double a, double bb) {
    config::Wall w = wall(config::WallKind::Rectangle, mat, centre, n);
    w.u = u;
    w.size_m = {a, bb};
    return w;
  };
  auto sink_below = [&](double y) {
    config::Sink k;
    k.kind = config::SinkKind::BelowPlane;
    k.point_m = {0.0, y, 0.0};
    k.normal = {0.0, 1.0, 0.0};
    cfg_.sinks.push_back(k);
  };
  auto phase_rest = [&](const std::string& name, double cap) {
    config::Phase p;
    p.name = name;
    p.length = config::PhaseLength::Duration;
    p.until_mean_kinetic_energy_j = 0.0;  // resolved once the particle mass is known
    p.max_duration_s = cap;
    p.duration_s = cap;
    p.settle_hold_s = b.rest_hold_s;
    p.translational_criterion = true;
    return p;
  };
  auto phase_move = [&](const std::string& name, std::size_t wall_index, double speed, double distance) {
    config::Phase p;
    p.name = name;
    p.length = config::PhaseLength::Duration;
    p.duration_s = distance / speed;
    p.move_wall = wall_index;
    p.move_velocity_m_s = {0.0, speed, 0.0};
    return p;
  };
  const toml::table* t = single(block);
  if (std::string_view(block) == "heap") {
    std::vector<std::string_view> keys = {"cylinder_diameter_m", "cylinder_height_m", "lift_speed_m_s",
                                          "lift_margin_m", "base_diameter_m", "cylinder_material",
                                          "base_material", "fit_from_fraction", "fit_to_fraction", "sectors"};
    keys.insert(keys.end(), rest_keys.begin(), rest_keys.end());
    Reader r(file_, *t, path, false, keys);
    b.kind = config::BulkTest::Kind::Heap;
    b.cylinder_diameter_m = r.real_or("cylinder_diameter_m", 0.06, kPositive);
    b.cylinder_height_m = r.real_or("cylinder_height_m", 2.5 * b.cylinder_diameter_m, kPositive);
    b.lift_speed_m_s = r.real_or("lift_speed_m_s", 0.05, kPositive);
    if (r.node("lift_margin_m")) b.lift_margin_m = r.real_or("lift_margin_m", 0.0, kPositive);
    b.base_diameter_m = r.real_or("base_diameter_m", 4.0 * b.cylinder_diameter_m, kPositive);
    if (!(b.base_diameter_m > b.cylinder_diameter_m))
      r.fail("base_diameter_m", "must exceed cylinder_diameter_m (the heap spreads beyond the cylinder)");
    b.cylinder_material = material_ref(r, "cylinder_material");
    b.base_material = material_ref(r, "base_material");
    b.fit_from_fraction = r.real_or("fit_from_fraction", 0.2, kUnitOpen);
    b.fit_to_fraction = r.real_or("fit_to_fraction", 0.8, kUnitOpen);
    if (!(b.fit_to_fraction > b.fit_from_fraction)) r.fail("fit_to_fraction", "must exceed fit_from_fraction");
    // (an integer key: 6.0 is refused, as for every integer key; 4 to 8 vertical half-planes of
    // the surface fit, SPEC 7)
    if (const auto k = r.opt_uint("sectors", 4, 8)) b.sectors = static_cast<std::size_t>(*k);
    read_rest(r, true);
    config::Wall base = wall(config::WallKind::Disc, b.base_material, {0, 0, 0}, {0, 1, 0});
    base.radius_m = 0.5 * b.base_diameter_m;
    cfg_.walls.push_back(base);
    config::Wall tube = wall(config::WallKind::Cylinder, b.cylinder_material, {0, 0, 0}, {0, 1, 0});
    tube.radius_m = 0.5 * b.cylinder_diameter_m;
    tube.length_m = b.cylinder_height_m;
    const std::size_t tube_index = cfg_.walls.size();
    cfg_.walls.push_back(tube);
    sink_below(-0.25 * b.cylinder_diameter_m);
    ins.region = config::Insertion::Region::Cylinder;
    ins.region_base_m = {0, 0, 0};
    ins.region_axis = {0, 1, 0};
    ins.region_radius_m = 0.5 * b.cylinder_diameter_m;
    ins.region_height_m = b.cylinder_height_m;
    config::Phase lift = phase_move("lift", tube_index, b.lift_speed_m_s, b.cylinder_height_m);
    lift.move_by_fill_height = true;  // margin resolved with the particle size
    cfg_.phases = {phase_rest("fill", b.max_fill_s), lift, phase_rest("rest", b.max_rest_s)};
  } else if (std::string_view(block) == "bulk_density") {
    std::vector<std::string_view> keys = {"container_diameter_m", "container_height_m", "container_material",
                                          "pour_height_factor"};
    keys.insert(keys.end(), rest_keys.begin(), rest_keys.end());
    Reader r(file_, *t, path, false, keys);
    b.kind = config::BulkTest::Kind::BulkDensity;
    b.container_diameter_m = r.real_or("container_diameter_m", 0.08, kPositive);
    b.container_height_m = r.real_or("container_height_m", 0.08, kPositive);
    b.container_material = material_ref(r, "container_material");
    b.pour_height_factor = r.real_or("pour_height_factor", 1.5, kPositive);
    if (!(b.pour_height_factor > 1.0)) r.fail("pour_height_factor", "must exceed 1 (the container must overflow)");
    read_rest(r, false);
    config::Wall bottom = wall(config::WallKind::Disc, b.container_material, {0, 0, 0}, {0, 1, 0});
    bottom.radius_m = 0.5 * b.container_diameter_m;
    cfg_.walls.push_back(bottom);
    config::Wall tube = wall(config::WallKind::Cylinder, b.container_material, {0, 0, 0}, {0, 1, 0});
    tube.radius_m = 0.5 * b.container_diameter_m;
    tube.length_m = b.container_height_m;
    cfg_.walls.push_back(tube);
    sink_below(-0.25 * b.container_height_m);
    ins.region = config::Insertion::Region::Cylinder;
    ins.region_base_m = {0, 0, 0};
    ins.region_axis = {0, 1, 0};
    ins.region_radius_m = 0.5 * b.container_diameter_m;
    ins.region_height_m = b.pour_height_factor * b.container_height_m;
    cfg_.phases = {phase_rest("fill", b.max_fill_s)};
  } else {
    std::vector<std::string_view> keys = {"length_m", "width_m", "height_m", "gate_lift_speed_m_s", "material"};
    keys.insert(keys.end(), rest_keys.begin(), rest_keys.end());
    Reader r(file_, *t, path, false, keys);
    b.kind = config::BulkTest::Kind::ShearBox;
    b.length_m = r.real_or("length_m", 0.08, kPositive);
    b.width_m = r.real_or("width_m", 0.08, kPositive);
    b.height_m = r.real_or("height_m", 0.08, kPositive);
    b.gate_lift_speed_m_s = r.real_or("gate_lift_speed_m_s", 0.1, kPositive);
    b.material = material_ref(r, "material");
    read_rest(r, true);
    const double L = b.length_m, W = b.width_m, H = b.height_m;
    cfg_.walls.push_back(rect(b.material, {0.5 * L, 0, 0}, {0, 1, 0}, {1, 0, 0}, L, W));            // bottom
    cfg_.walls.push_back(rect(b.material, {0, 0.5 * H, 0}, {1, 0, 0}, {0, 1, 0}, H, W));            // back
    cfg_.walls.push_back(rect(b.material, {0.5 * L, 0.5 * H, -0.5 * W}, {0, 0, 1}, {1, 0, 0}, L, H));  // sides
    cfg_.walls.push_back(rect(b.material, {0.5 * L, 0.5 * H, 0.5 * W}, {0, 0, -1}, {1, 0, 0}, L, H));
    const std::size_t gate = cfg_.walls.size();
    cfg_.walls.push_back(rect(b.material, {L, 0.5 * H, 0}, {-1, 0, 0}, {0, 1, 0}, H, W));
    sink_below(-0.25 * H);
    ins.region = config::Insertion::Region::Box;
    ins.region_min_m = {0, 0, -0.5 * W};
    ins.region_max_m = {L, H, 0.5 * W};
    cfg_.phases = {phase_rest("fill", b.max_fill_s), phase_move("gate", gate, b.gate_lift_speed_m_s, H),
                   phase_rest("rest", b.max_rest_s)};
  }
  cfg_.bulk_test = b;
}

// The rest criterion in joules: rest_fraction x m g d with the mean particle mass and the
// volume-equivalent diameter of the poured population (number-weighted).
void CaseParser::resolve_bulk_test() {
  if (!cfg_.bulk_test) return;
  auto& b = *cfg_.bulk_test;
  const double g = -cfg_.run.gravity_m_s2[1];
  double w = 0.0, m = 0.0, d = 0.0;
  for (const auto& p : cfg_.populations) {
    const auto& t = templates_.at(p.shape);
    const double n = p.volume_fraction / t.volume_m3;  // number weight
    m += n * t.volume_m3 * cfg_.materials[p.material].density_kg_m3.value_or(0.0);
    d += n * t.equivalent_diameter_m();
    w += n;
  }
  b.rest_mean_kinetic_energy_j = b.rest_fraction * (m / w) * g * (d / w);
  for (auto& p : cfg_.phases)
    if (p.until_mean_kinetic_energy_j) p.until_mean_kinetic_energy_j = b.rest_mean_kinetic_energy_j;
  if (b.kind == config::BulkTest::Kind::Heap) {
    double length = 0.0;  // the longest poured particle (bounding diameter)
    for (const auto& p : cfg_.populations) length = std::max(length, 2.0 * templates_.at(p.shape).bounding_radius_m);
    if (!b.lift_margin_m) b.lift_margin_m = 2.0 * length;
    for (auto& p : cfg_.phases)
      if (p.move_by_fill_height) p.move_margin_m = *b.lift_margin_m;
  }
}

}  // namespace biodem::case_file::detail
