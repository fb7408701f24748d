// Case file (SPEC 11; docs/case_file.md): [drum], [[wall]], [[sink]], [[particle]] and [domain].
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <string>
#include <vector>


#include "case_file/case_parser_detail.hpp"
#include "core/quat.hpp"
#include "walls/wall_from_config.hpp"
#include "walls/wall_geometry.hpp"

namespace biodem::case_file::detail {

void CaseParser::parse_drum() {
  const toml::table* t = single("drum");
  if (!t) {
    if (cfg_.insertion && cfg_.insertion->region == config::Insertion::Region::Drum)
      fail("[drum]: required by [insertion] (particles are inserted into the drum)");
    return;
  }
  Reader r(file_, *t, "[drum]", false,
           {"diameter_m", "width_m", "rpm", "mantle_material", "endplate_material", "axial_boundary"});
  config::Drum d;
  d.diameter_m = r.real("diameter_m", kPositive);
  d.width_m = r.real("width_m", kPositive);
  d.rpm = r.real("rpm", kAny);
  d.mantle_material = material_ref(r, "mantle_material");
  const std::string ab = r.opt_string("axial_boundary").value_or("endplates");
  if (ab == "endplates")
    d.axial_boundary = config::AxialBoundary::EndPlates;
  else if (ab == "periodic")
    d.axial_boundary = config::AxialBoundary::Periodic;
  else
    r.fail("axial_boundary", "must be \"endplates\" or \"periodic\"");
  if (d.axial_boundary == config::AxialBoundary::EndPlates) {
    if (!r.has("endplate_material")) r.missing("endplate_material", " (or set axial_boundary = \"periodic\")");
    d.endplate_material = material_ref(r, "endplate_material");
  } else if (r.has("endplate_material")) {
    r.fail("endplate_material", "a periodic drum (axial_boundary = \"periodic\") has no end plates");
  }
  if (!cfg_.insertion) fail("[insertion]: required with [drum] (count or fill_fraction of the particles to insert)");
  cfg_.drum = d;
}

void CaseParser::parse_walls() {
  const auto list = entries("wall");
  for (std::size_t i = 0; i < list.size(); ++i) {
    // angular_velocity_rad_s: prescribed rotation of the wall about its own symmetry axis,
    // the line through point_m along `normal` (plane, disc) or `axis` (cylinder); right-hand
    // rule. The geometry stays put; only the surface velocity omega x r is prescribed.
    Reader r(file_, *list[i], entry_path("wall", i), true,
             {"kind", "material", "point_m", "normal", "axis", "radius_m", "length_m", "angular_velocity_rad_s", "u",
              "size_m", "translation_velocity_m_s", "move_start_s", "move_end_s"});
    config::Wall w;
    const std::string kind = r.string("kind");
    std::vector<std::string_view> own;
    if (kind == "plane") {
      w.kind = config::WallKind::Plane;
      own = {"normal"};
    } else if (kind == "disc") {
      w.kind = config::WallKind::Disc;
      own = {"normal", "radius_m"};
    } else if (kind == "cylinder") {
      w.kind = config::WallKind::Cylinder;
      own = {"axis", "radius_m", "length_m"};
    } else if (kind == "rectangle") {
      w.kind = config::WallKind::Rectangle;
      own = {"normal", "u", "size_m"};
    } else {
      r.fail("kind", "must be \"plane\", \"disc\", \"cylinder\" or \"rectangle\"");
    }
    for (auto k : {"normal", "axis", "radius_m", "length_m", "u", "size_m"})
      if (r.has(k) && std::find(own.begin(), own.end(), std::string_view(k)) == own.end())
        r.fail(k, "not a key of kind \"" + kind + "\" (its own keys: " + join(own) + ")");
    w.material = material_ref(r, "material");
    w.point_m = r.vec3("point_m");
    if (w.kind == config::WallKind::Cylinder) {
      w.normal = r.unit_vec3("axis");
      w.radius_m = r.real("radius_m", kPositive);
      w.length_m = r.real_or("length_m", 0.0, kNonNegative);
    } else {
      w.normal = r.unit_vec3("normal");
      if (w.kind == config::WallKind::Disc) w.radius_m = r.real("radius_m", kPositive);
    }
    if (w.kind == config::WallKind::Rectangle) {
      w.u = r.unit_vec3("u");
      const double c = w.u[0] * w.normal[0] + w.u[1] * w.normal[1] + w.u[2] * w.normal[2];
      if (std::abs(c) > 1e-6) r.fail("u", "must be perpendicular to normal (u . normal = " + num(c, 3) + ")");
      auto sz = r.opt_numbers("size_m", 2, "[length along u, length along normal x u]");
      if (!sz) r.missing("size_m", "");
      if (!((*sz)[0] > 0.0) || !((*sz)[1] > 0.0)) r.fail("size_m", "both sides must be positive");
      w.size_m = {(*sz)[0], (*sz)[1]};
    }
    w.angular_velocity_rad_s = r.real_or("angular_velocity_rad_s", 0.0);
    if (auto v = r.opt_vec3("translation_velocity_m_s")) {
      w.translation_velocity_m_s = *v;
      w.move_start_s = r.real_or("move_start_s", 0.0, kNonNegative);
      if (!r.has("move_end_s")) r.missing("move_end_s", " (when the wall stops; translation_velocity_m_s is set)");
      w.move_end_s = r.real("move_end_s", kPositive);
      if (!(w.move_end_s > w.move_start_s)) r.fail("move_end_s", "must be later than move_start_s");
    } else {
      for (auto k : {"move_start_s", "move_end_s"})
        if (r.has(k)) r.fail(k, "needs translation_velocity_m_s (the wall does not move)");
    }
    cfg_.walls.push_back(w);
  }
}

void CaseParser::parse_sinks() {
  const auto list = entries("sink");
  for (std::size_t i = 0; i < list.size(); ++i) {
    Reader r(file_, *list[i], entry_path("sink", i), true, {"kind", "point_m", "normal", "min_m", "max_m"});
    config::Sink k;
    const std::string kind = r.string("kind");
    std::vector<std::string_view> own;
    if (kind == "below_plane") {
      k.kind = config::SinkKind::BelowPlane;
      own = {"point_m", "normal"};
    } else if (kind == "outside_box") {
      k.kind = config::SinkKind::OutsideBox;
      own = {"min_m", "max_m"};
    } else {
      r.fail("kind", "must be \"below_plane\" or \"outside_box\"");
    }
    for (auto key : {"point_m", "normal", "min_m", "max_m"})
      if (r.has(key) && std::find(own.begin(), own.end(), std::string_view(key)) == own.end())
        r.fail(key, "not a key of kind \"" + kind + "\" (its own keys: " + join(own) + ")");
    if (k.kind == config::SinkKind::BelowPlane) {
      k.point_m = r.vec3("point_m");
      k.normal = r.unit_vec3("normal");
    } else {
      k.min_m = r.vec3("min_m");
      k.max_m = r.vec3("max_m");
      for (int a = 0; a < 3; ++a)
        if (!(k.max_m[a] > k.min_m[a])) r.fail("max_m", "must exceed min_m along every axis");
    }
    cfg_.sinks.push_back(k);
  }
}

void CaseParser::parse_particles() {
  const auto list = entries("particle");
  for (std::size_t i = 0; i < list.size(); ++i) {
    Reader r(file_, *list[i], entry_path("particle", i), true,
             {"shape", "material", "position_m", "velocity_m_s", "angular_velocity_rad_s", "orientation"});
    config::Particle p;
    p.shape = shape_ref(r, "shape");
    p.material = material_ref(r, "material");
    p.position_m = r.vec3("position_m");
    p.velocity_m_s = r.opt_vec3("velocity_m_s").value_or(config::Vec3d{});
    p.angular_velocity_rad_s = r.opt_vec3("angular_velocity_rad_s").value_or(config::Vec3d{});
    if (auto q = r.opt_numbers("orientation", 4, "[w, x, y, z] (a quaternion)")) {
      const double n = std::sqrt((*q)[0] * (*q)[0] + (*q)[1] * (*q)[1] + (*q)[2] * (*q)[2] + (*q)[3] * (*q)[3]);
      if (!(n > 0.0)) r.fail("orientation", "must be a non-zero quaternion [w, x, y, z]");
      p.orientation = {(*q)[0] / n, (*q)[1] / n, (*q)[2] / n, (*q)[3] / n};
    }
    cfg_.particles.push_back(p);
  }
}

void CaseParser::parse_domain() {
  const toml::table* t = single("domain");
  if (!t) return;
  Reader r(file_, *t, "[domain]", false, {"min_m", "max_m", "periodic"});
  config::Domain d;
  d.min_m = r.vec3("min_m");
  d.max_m = r.vec3("max_m");
  for (int k = 0; k < 3; ++k)
    if (!(d.max_m[k] > d.min_m[k]))
      r.fail("max_m", "must exceed [domain].min_m on every axis (axis " + std::string(1, "xyz"[k]) + ")");
  if (const toml::node* n = r.node("periodic")) {
    const toml::array* a = n->as_array();
    if (!a || a->size() != 3 || !std::all_of(a->begin(), a->end(), [](const toml::node& e) { return e.is_boolean(); }))
      r.fail("periodic", "must be an array of 3 booleans [x, y, z]");
    for (std::size_t k = 0; k < 3; ++k) d.periodic[k] = a->get(k)->as_boolean()->get();
  }
  cfg_.domain = d;
}

}  // namespace biodem::case_file::detail
