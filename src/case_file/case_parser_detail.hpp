// The case parser's state and its passes (case_parser.cpp runs them in order): one member
// function per table, defined in the file of its table (parse_<table>.cpp), and the checks
// across tables (cross_checks.cpp). Internal to src/case_file.
#pragma once
#include <toml++/toml.h>

#include <cstddef>
#include <map>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "case_file/case_parser.hpp"
#include "case_file/toml_reader.hpp"
#include "config/case_config.hpp"
#include "shapes/clump_template.hpp"

namespace biodem::case_file::detail {

class CaseParser {
 public:
  CaseParser(const toml::table& root, std::string file) : root_(root), file_(std::move(file)) {}

  /// Both passes, in order; the parsed case and its warnings.
  LoadedCase parse();

 private:
  const toml::table& root_;
  std::string file_;
  config::CaseConfig cfg_;
  std::vector<std::string> warnings_;
  std::map<std::string, std::size_t> material_index_, shape_index_;
  std::map<std::size_t, shapes::ClumpTemplate> templates_;  // shapes in use, after coarse graining

  [[noreturn]] void fail(const std::string& msg) const { throw Error(file_ + ": " + msg); }
  void warn(const std::string& msg) { warnings_.push_back(file_ + ": " + msg); }

  // ---------------------------------------------------------------- table access
  static constexpr std::string_view kSingle[] = {"run",  "insertion",    "drum",     "domain",  "output",
                                                 "heap", "bulk_density", "shear_box", "contact"};
  static constexpr std::string_view kArrays[] = {"material", "pair",     "shape", "population",
                                                 "wall",     "particle", "phase", "sink"};

  /// Every top-level key is a known table of the right kind ([x] or [[x]]).
  void check_top_level() const;

  const toml::table* single(std::string_view name) const { return root_.get_as<toml::table>(name); }
  std::vector<const toml::table*> entries(std::string_view name) const {
    std::vector<const toml::table*> out;
    if (auto a = root_.get_as<toml::array>(name))
      for (const auto& e : *a) out.push_back(e.as_table());
    return out;
  }
  static std::string entry_path(std::string_view table, std::size_t i, const std::string& label = "") {
    return "[[" + std::string(table) + "]] #" + std::to_string(i + 1) + (label.empty() ? "" : " (" + label + ")");
  }
  static std::string name_label(const toml::table& t, std::string_view key = "name") {
    if (auto s = t.get_as<std::string>(key)) return s->get();
    return "";
  }

  std::size_t material_ref(const Reader& r, std::string_view key) const {
    const std::string name = r.string(key);
    auto it = material_index_.find(name);
    if (it == material_index_.end()) r.fail(key, "no [[material]] has this name" + known(material_index_));
    return it->second;
  }
  std::size_t shape_ref(const Reader& r, std::string_view key) const {
    const std::string name = r.string(key);
    auto it = shape_index_.find(name);
    if (it == shape_index_.end()) r.fail(key, "no [[shape]] has this name" + known(shape_index_));
    return it->second;
  }
  static std::string known(const std::map<std::string, std::size_t>& m) {
    if (m.empty()) return " (none is defined)";
    std::string s;
    for (const auto& [k, v] : m) s += (s.empty() ? "" : ", ") + k;
    return " (defined: " + s + ")";
  }
  const std::string& mat_name(std::size_t i) const { return cfg_.materials[i].name; }

  // ---------------------------------------------------------------- tables (first pass) and cross checks
  // parse_run.cpp
  void parse_run();
  void parse_contact();
  void parse_phases();
  void parse_output();
  // parse_materials.cpp
  void parse_materials();
  void parse_pairs();
  // parse_shapes.cpp
  void parse_shapes();
  void parse_populations();
  void parse_insertion();
  // [insertion] region and mode (issue 9): the drum (default when there is a [drum]), or a box
  // or finite cylinder of any scene.
  void parse_insertion_region(const Reader& r, config::Insertion& ins) const;
  // parse_scene.cpp
  void parse_drum();
  void parse_walls();
  void parse_sinks();
  void parse_particles();
  void parse_domain();
  // parse_bulk_test.cpp
  const char* bulk_block() const;
  // Expands [heap], [bulk_density] or [shear_box] into walls, a sink, the insertion region and
  // the phases. y is up; gravity must point along -y. Default dimensions: docs/calibration.md.
  void parse_bulk_test();
  // The rest criterion in joules: rest_fraction x m g d with the mean particle mass and the
  // volume-equivalent diameter of the poured population (number-weighted).
  void resolve_bulk_test();
  // cross_checks.cpp
  void check_something_to_simulate() const;
  void check_output_cadence();
  void check_unused();  // (and the outputs a drum case leaves out)
  std::set<std::size_t> particle_materials() const;
  void check_particle_densities() const;
  void check_pairs_complete() const;
  void build_templates();
  void check_insertion_feasible() const;
  // Same rules as the drum: every shape fits the region; a packed region cannot take more
  // solid than the drum's limit (poured waves are limited by the three-empty-waves rule at run time).
  void check_region_feasible() const;
  void check_periodic_cells() const;
  void check_walls_across_periodic_axes() const;
  void check_particles_inside_bounds() const;
  void check_initial_overlaps() const;
  void check_time_step();
};

}  // namespace biodem::case_file::detail
