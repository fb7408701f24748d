// Case file (SPEC 11; docs/case_file.md): [[material]] and [[pair]].
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <string>
#include <vector>


#include "case_file/case_parser_detail.hpp"

namespace biodem::case_file::detail {

void CaseParser::parse_materials() {
  const auto list = entries("material");
  if (list.empty()) fail("[[material]]: at least one material is required");
  for (std::size_t i = 0; i < list.size(); ++i) {
    Reader r(file_, *list[i], entry_path("material", i, name_label(*list[i])), true,
             {"name", "density_kg_m3", "young_pa", "poisson"});
    config::Material m;
    m.name = r.string("name");
    if (m.name.empty()) r.fail("name", "must not be empty");
    if (material_index_.count(m.name))
      r.fail("name", "duplicate material name (also [[material]] #" + std::to_string(material_index_[m.name] + 1) +
                         ")");
    m.density_kg_m3 = r.opt_real("density_kg_m3", kPositive);
    m.young_pa = r.real("young_pa", kPositive);
    m.poisson = r.real("poisson", kAny);
    if (m.poisson >= 0.5)
      r.fail("poisson", "must be < 0.5 (0.5 is an incompressible solid; the Hertz moduli need nu in (-1, 0.5))");
    if (m.poisson <= -1.0) r.fail("poisson", "must be > -1");
    material_index_[m.name] = cfg_.materials.size();
    cfg_.materials.push_back(std::move(m));
  }
}

void CaseParser::parse_pairs() {
  const auto list = entries("pair");
  std::map<std::pair<std::size_t, std::size_t>, std::size_t> seen;
  for (std::size_t i = 0; i < list.size(); ++i) {
    std::string label;
    if (auto a = list[i]->get_as<toml::array>("materials"); a && a->size() == 2 && a->get(0)->is_string() &&
                                                             a->get(1)->is_string())
      label = "materials " + a->get(0)->as_string()->get() + "/" + a->get(1)->as_string()->get();
    Reader r(file_, *list[i], entry_path("pair", i, label), true,
             {"materials", "restitution", "sliding_friction", "rolling_friction", "cohesion_energy_density_j_m3"});
    config::PairTable p;
    const toml::node* mn = r.node("materials");
    if (!mn) r.missing("materials", " (materials = [\"a\", \"b\"])");
    const toml::array* a = mn->as_array();
    if (!a || a->size() != 2 || !a->get(0)->is_string() || !a->get(1)->is_string())
      r.fail("materials", "must be an array of two material names, e.g. [\"bead\", \"steel\"]");
    std::size_t ab[2];
    for (int k = 0; k < 2; ++k) {
      const std::string& nm = a->get(static_cast<std::size_t>(k))->as_string()->get();
      auto it = material_index_.find(nm);
      if (it == material_index_.end())
        r.fail("materials", "no [[material]] named \"" + nm + "\"" + known(material_index_));
      ab[k] = it->second;
    }
    p.material_a = ab[0];
    p.material_b = ab[1];
    const auto key = std::minmax(p.material_a, p.material_b);
    if (auto it = seen.find(key); it != seen.end())
      r.fail("materials", "duplicate pair (also [[pair]] #" + std::to_string(it->second + 1) + ")");
    seen[key] = i;
    p.restitution = r.real("restitution", kUnitOpenClosed);
    p.sliding_friction = r.real("sliding_friction", kNonNegative);
    p.rolling_friction = r.real_or("rolling_friction", 0.0, kNonNegative);
    p.cohesion_energy_density_j_m3 = r.real_or("cohesion_energy_density_j_m3", 0.0, kNonNegative);
    cfg_.pairs.push_back(p);
  }
}

}  // namespace biodem::case_file::detail
