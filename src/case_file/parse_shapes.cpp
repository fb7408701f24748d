// Case file (SPEC 11; docs/case_file.md): [[shape]], [[population]] and [insertion] (with its
// region).
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <string>
#include <vector>


#include "case_file/case_parser_detail.hpp"
#include "case_file/derived_quantities.hpp"

namespace biodem::case_file::detail {

void CaseParser::parse_shapes() {
  const auto list = entries("shape");
  for (std::size_t i = 0; i < list.size(); ++i) {
    Reader r(file_, *list[i], entry_path("shape", i, name_label(*list[i])), true,
             {"name", "kind", "diameter_m", "d50_m", "aspect_ratio", "overlap_factor", "spheres"});
    config::Shape s;
    s.name = r.string("name");
    if (s.name.empty()) r.fail("name", "must not be empty");
    if (shape_index_.count(s.name))
      r.fail("name", "duplicate shape name (also [[shape]] #" + std::to_string(shape_index_[s.name] + 1) + ")");
    const std::string kind = r.string("kind");
    std::vector<std::string_view> own;
    if (kind == "sphere") {
      s.kind = config::ShapeKind::Sphere;
      own = {"diameter_m"};
    } else if (kind == "needle") {
      s.kind = config::ShapeKind::Needle;
      own = {"d50_m", "aspect_ratio", "overlap_factor"};
    } else if (kind == "clump") {
      s.kind = config::ShapeKind::Clump;
      own = {"spheres"};
    } else {
      r.fail("kind", "must be \"sphere\", \"needle\" or \"clump\"");
    }
    for (auto k : {"diameter_m", "d50_m", "aspect_ratio", "overlap_factor", "spheres"})
      if (r.has(k) && std::find(own.begin(), own.end(), std::string_view(k)) == own.end())
        r.fail(k, "not a key of kind \"" + kind + "\" (its keys: " + join(own) + ")");
    switch (s.kind) {
      case config::ShapeKind::Sphere:
        s.diameter_m = r.real("diameter_m", kPositive);
        break;
      case config::ShapeKind::Needle:
        s.d50_m = r.real("d50_m", kPositive);
        s.aspect_ratio = r.real("aspect_ratio", kUnitOpenClosed);
        s.overlap_factor = r.real_or("overlap_factor", 0.2, Range{0.0, 1.0, true, false});
        {
          // SPEC 3's n_spb, checked before the clump is built (its mass properties cost n^2): a
          // tiny aspect ratio or an overlap factor near 1 gave millions of spheres per needle
          // (hours before any other check), or an int overflow read as 1 sphere.
          constexpr double kMostSpheresPerNeedle = 1000.0;
          const double n = std::round((1.0 / s.aspect_ratio - s.overlap_factor) / (1.0 - s.overlap_factor));
          if (!(n <= kMostSpheresPerNeedle))
            r.fail("aspect_ratio", num(s.aspect_ratio) + " with overlap_factor " + num(s.overlap_factor) +
                                       " gives n_spb = " + num(n) + " spheres per needle (SPEC 3); at most " +
                                       num(kMostSpheresPerNeedle));
        }
        if (s.overlap_factor > 0.5)
          warn(r.where("overlap_factor") + " = " + num(s.overlap_factor) +
               ": above 0.5 more than two spheres overlap at a point; volume and inertia come from a numerical "
               "integration instead of the exact lens formula (SPEC 3)");
        break;
      case config::ShapeKind::Clump: {
        const toml::node* n = r.node("spheres");
        if (!n) r.missing("spheres", " (spheres = [[x_m, y_m, z_m, r_m], ...])");
        const toml::array* a = n->as_array();
        const std::string form = "must be a non-empty array of [x_m, y_m, z_m, r_m] arrays";
        if (!a || a->empty()) r.fail("spheres", form);
        for (std::size_t k = 0; k < a->size(); ++k) {
          const toml::array* e = a->get(k)->as_array();
          if (!e || e->size() != 4) r.fail("spheres", form + " (entry " + std::to_string(k + 1) + ")");
          double v[4];
          for (std::size_t j = 0; j < 4; ++j) {
            const toml::node* x = e->get(j);
            if (auto f = x->as_floating_point())
              v[j] = f->get();
            else if (auto in = x->as_integer())
              v[j] = static_cast<double>(in->get());
            else
              r.fail("spheres", form + " (entry " + std::to_string(k + 1) + " has " + type_name(*x) + ")");
            if (!std::isfinite(v[j])) r.fail("spheres", "entry " + std::to_string(k + 1) + ": must be finite");
          }
          if (!(v[3] > 0.0)) r.fail("spheres", "entry " + std::to_string(k + 1) + ": radius must be > 0");
          s.spheres.push_back({{v[0], v[1], v[2]}, v[3]});
        }
        break;
      }
    }
    shape_index_[s.name] = cfg_.shapes.size();
    cfg_.shapes.push_back(std::move(s));
  }
}

void CaseParser::parse_populations() {
  const auto list = entries("population");
  double sum = 0.0;
  for (std::size_t i = 0; i < list.size(); ++i) {
    Reader r(file_, *list[i], entry_path("population", i), true, {"shape", "material", "volume_fraction"});
    config::Population p;
    p.shape = shape_ref(r, "shape");
    p.material = material_ref(r, "material");
    if (list.size() == 1)
      p.volume_fraction = r.real_or("volume_fraction", 1.0, kUnitOpenClosed);
    else
      p.volume_fraction = r.real("volume_fraction", kUnitOpenClosed);
    sum += p.volume_fraction;
    cfg_.populations.push_back(p);
  }
  if (!list.empty() && std::abs(sum - 1.0) > 1e-6)
    fail("[[population]] .volume_fraction: the fractions sum to " + num(sum, 10) + ", must sum to 1");
}

void CaseParser::parse_insertion() {
  const toml::table* t = single("insertion");
  if (!t) return;
  Reader r(file_, *t, "[insertion]", false,
           {"count", "fill_fraction", "bulk_solid_fraction", "coarse_grain", "max_attempts_per_particle",
            "wave_fall_s", "region", "mode", "region_min_m", "region_max_m", "region_base_m", "region_axis",
            "region_radius_m", "region_height_m"});
  config::Insertion ins;
  ins.count = r.opt_uint("count", 1);
  ins.fill_fraction = r.opt_real("fill_fraction", kUnitOpen);
  if (ins.count && ins.fill_fraction)
    r.fail("fill_fraction", "give either [insertion].count or [insertion].fill_fraction, not both");
  if (!ins.count && !ins.fill_fraction) r.missing("count", " (give count or fill_fraction)");
  if (r.has("bulk_solid_fraction") && !ins.fill_fraction)
    r.fail("bulk_solid_fraction", "only used with [insertion].fill_fraction");
  ins.bulk_solid_fraction = r.real_or("bulk_solid_fraction", 0.6, kUnitOpen);
  ins.coarse_grain = r.real_or("coarse_grain", 1.0, kPositive);
  ins.max_attempts_per_particle = r.opt_uint("max_attempts_per_particle", 1).value_or(1000);
  ins.wave_fall_s = r.opt_real("wave_fall_s", kPositive);
  parse_insertion_region(r, ins);
  if (cfg_.populations.empty()) fail("[[population]]: required by [insertion] (what to insert), none given");
  cfg_.insertion = ins;
}

// [insertion] region and mode (issue 9): the drum (default when there is a [drum]), or a box
// or finite cylinder of any scene.
void CaseParser::parse_insertion_region(const Reader& r, config::Insertion& ins) const {
  using R = config::Insertion::Region;
  const bool drum = single("drum") != nullptr;
  if (const char* b = bulk_block()) {  // the bulk test sets the region (its container)
    for (auto k : {"region", "region_min_m", "region_max_m", "region_base_m", "region_axis", "region_radius_m",
                   "region_height_m"})
      if (r.has(k)) r.fail(k, std::string("the [") + b + "] test sets the insertion region itself");
    if (ins.fill_fraction) r.fail("fill_fraction", std::string("give [insertion].count for the [") + b + "] test");
    ins.region = config::Insertion::Region::Cylinder;  // replaced by parse_bulk_test
    const std::string mode = r.opt_string("mode").value_or("pour");
    if (mode == "pack") ins.mode = config::Insertion::Mode::Pack;
    else if (mode != "pour") r.fail("mode", "must be \"pour\" (waves) or \"pack\" (one wave)");
    return;
  }
  const std::string region = r.opt_string("region").value_or(drum ? "drum" : "");
  std::vector<std::string_view> own;
  if (region == "drum") {
    ins.region = R::Drum;
  } else if (region == "box") {
    ins.region = R::Box;
    own = {"region_min_m", "region_max_m"};
  } else if (region == "cylinder") {
    ins.region = R::Cylinder;
    own = {"region_base_m", "region_axis", "region_radius_m", "region_height_m"};
  } else if (region.empty()) {
    r.missing("region", " (\"box\" or \"cylinder\"; without [drum] there is no drum to fill)");
  } else {
    r.fail("region", "must be \"drum\", \"box\" or \"cylinder\"");
  }
  for (auto k : {"region_min_m", "region_max_m", "region_base_m", "region_axis", "region_radius_m", "region_height_m"})
    if (r.has(k) && std::find(own.begin(), own.end(), std::string_view(k)) == own.end())
      r.fail(k, "not a key of region \"" + region + "\"" + (own.empty() ? std::string() : " (its own keys: " + join(own) + ")"));
  if (ins.region == R::Box) {
    ins.region_min_m = r.vec3("region_min_m");
    ins.region_max_m = r.vec3("region_max_m");
    for (int a = 0; a < 3; ++a)
      if (!(ins.region_max_m[a] > ins.region_min_m[a])) r.fail("region_max_m", "must exceed region_min_m along every axis");
  } else if (ins.region == R::Cylinder) {
    ins.region_base_m = r.vec3("region_base_m");
    ins.region_axis = r.has("region_axis") ? r.unit_vec3("region_axis") : config::Vec3d{0, 1, 0};
    ins.region_radius_m = r.real("region_radius_m", kPositive);
    ins.region_height_m = r.real("region_height_m", kPositive);
  }
  if (ins.region != R::Drum && ins.fill_fraction)
    r.fail("fill_fraction", "only with the drum region; give [insertion].count for a box or cylinder region");
  const std::string mode = r.opt_string("mode").value_or("pour");
  if (mode == "pour")
    ins.mode = config::Insertion::Mode::Pour;
  else if (mode == "pack")
    ins.mode = config::Insertion::Mode::Pack;
  else
    r.fail("mode", "must be \"pour\" (waves) or \"pack\" (one wave)");
  if (ins.region == R::Drum && ins.mode == config::Insertion::Mode::Pack) r.fail("mode", "\"pack\" needs a box or cylinder region");
}

}  // namespace biodem::case_file::detail
