// Case file (TOML, SPEC 11) -> config::CaseConfig, with every check a case needs before
// anything is computed (SPEC 10; STYLE.md 6). Two passes:
//   1. table by table: types, ranges, required and unknown keys, references by name;
//   2. across tables: densities of particle materials, completeness of the pair table,
//      insertion feasibility, periodic cell size, initial overlaps of explicit particles, and
//      the time step against the Rayleigh time.
// Every error is one line: "<file>: <table path>.<key> = <value as written>: <reason>".
#include "io/case_parser.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <unordered_map>

#include "contact/time_step.hpp"
#include "core/error.hpp"
#include "core/quat.hpp"
#include "io/case_report.hpp"
#include "shapes/clump_template.hpp"
#include "walls/wall_from_config.hpp"
#include "walls/wall_geometry.hpp"

namespace biodem::io {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kMaxInsertableSolidFraction = 0.55;  // of the drum volume; random loose packing is ~0.55-0.6
constexpr double kDtWarnFraction = 0.20;              // SPEC 2.5
constexpr double kDtErrorFraction = 0.40;

std::string num(double v, int digits = 6) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

/// " (did you mean X?)" for the closest candidate within a few edits, else "".
std::string suggestion(std::string_view key, const std::vector<std::string_view>& candidates,
                       std::string_view prefix = "", std::string_view suffix = "") {
  std::string_view best;
  std::size_t best_d = std::numeric_limits<std::size_t>::max();
  for (auto c : candidates) {
    const std::size_t d = edit_distance(key, c);
    if (d < best_d) best_d = d, best = c;
  }
  if (best.empty() || best_d > std::max<std::size_t>(2, key.size() / 3)) return "";
  return " (did you mean " + std::string(prefix) + std::string(best) + std::string(suffix) + "?)";
}

std::string join(const std::vector<std::string_view>& v) {
  std::string s;
  for (auto x : v) s += (s.empty() ? "" : ", ") + std::string(x);
  return s;
}

/// A value as the user wrote it, for messages.
std::string show(const toml::node& n) {
  if (auto s = n.as_string()) return "\"" + s->get() + "\"";
  if (auto i = n.as_integer()) return std::to_string(i->get());
  if (auto f = n.as_floating_point()) return num(f->get(), 17 - 2);
  if (auto b = n.as_boolean()) return b->get() ? "true" : "false";
  if (auto a = n.as_array()) {
    std::string s = "[";
    for (std::size_t i = 0; i < a->size(); ++i) s += (i ? ", " : "") + show(*a->get(i));
    return s + "]";
  }
  if (n.is_table()) return "{...}";
  std::ostringstream os;
  n.visit([&](const auto& x) { os << x; });
  return os.str();
}

std::string type_name(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a real number";
    case toml::node_type::boolean: return "a boolean";
    case toml::node_type::array: return "an array";
    case toml::node_type::table: return "a table";
    default: return "a date/time";
  }
}

/// Allowed interval of a real value, with its wording for messages.
struct Range {
  double lo = -kInf, hi = kInf;
  bool lo_incl = true, hi_incl = true;
  bool contains(double v) const {
    return (lo_incl ? v >= lo : v > lo) && (hi_incl ? v <= hi : v < hi);
  }
  std::string text() const {
    if (hi == kInf) return std::string("must be ") + (lo_incl ? ">= " : "> ") + num(lo);
    if (lo == -kInf) return std::string("must be ") + (hi_incl ? "<= " : "< ") + num(hi);
    return "must be in " + std::string(lo_incl ? "[" : "(") + num(lo) + ", " + num(hi) + (hi_incl ? "]" : ")");
  }
};
constexpr Range kAny{};
constexpr Range kPositive{0.0, kInf, false, true};
constexpr Range kNonNegative{0.0, kInf, true, true};
constexpr Range kUnitOpenClosed{0.0, 1.0, false, true};  // (0, 1]
constexpr Range kUnitOpen{0.0, 1.0, false, false};       // (0, 1)

/// Reads the keys of one table with typed accessors; every message names the file, the table
/// path and the key. Unknown keys are rejected on construction.
class Reader {
 public:
  Reader(const std::string& file, const toml::table& t, std::string path, bool array_entry,
         std::initializer_list<std::string_view> allowed)
      : file_(file), t_(t), path_(std::move(path)), array_entry_(array_entry), allowed_(allowed) {
    for (auto&& [k, v] : t_) {
      const std::string_view key = k.str();
      if (std::find(allowed_.begin(), allowed_.end(), key) == allowed_.end())
        throw Error(file_ + ": unknown key " + where(key) + suggestion(key, allowed_) + "; allowed keys: " +
                    join(allowed_));
    }
  }

  Reader(const std::string& file, const toml::table& t, std::string path, bool array_entry,
         const std::vector<std::string_view>& allowed)
      : file_(file), t_(t), path_(std::move(path)), array_entry_(array_entry), allowed_(allowed) {
    for (auto&& [k, v] : t_) {
      const std::string_view key = k.str();
      if (std::find(allowed_.begin(), allowed_.end(), key) == allowed_.end())
        throw Error(file_ + ": unknown key " + where(key) + suggestion(key, allowed_) + "; allowed keys: " +
                    join(allowed_));
    }
  }

  const std::string& path() const { return path_; }
  std::string where(std::string_view key) const { return path_ + (array_entry_ ? " ." : ".") + std::string(key); }
  bool has(std::string_view key) const { return t_.contains(key); }
  const toml::node* node(std::string_view key) const { return t_.get(key); }

  /// "<file>: <path>.<key> = <value>: <reason>" (without "= value" if the key is absent).
  [[noreturn]] void fail(std::string_view key, const std::string& reason) const {
    const toml::node* n = t_.get(key);
    throw Error(file_ + ": " + where(key) + (n ? " = " + show(*n) : std::string()) + ": " + reason);
  }
  [[noreturn]] void missing(std::string_view key, const std::string& what = "") const {
    throw Error(file_ + ": " + where(key) + ": required key is missing" + what);
  }

  // --- reals (TOML integers are accepted and converted) ---
  std::optional<double> opt_real(std::string_view key, Range r = kAny) const {
    const toml::node* n = t_.get(key);
    if (!n) return std::nullopt;
    double v;
    if (auto f = n->as_floating_point())
      v = f->get();
    else if (auto i = n->as_integer())
      v = static_cast<double>(i->get());
    else
      fail(key, "must be a number, not " + type_name(*n));
    if (!std::isfinite(v)) fail(key, "must be a finite number");
    if (!r.contains(v)) fail(key, r.text());
    return v;
  }
  double real(std::string_view key, Range r = kAny) const {
    if (!has(key)) missing(key);
    return *opt_real(key, r);
  }
  double real_or(std::string_view key, double def, Range r = kAny) const { return opt_real(key, r).value_or(def); }

  // --- integers (reals are rejected, even 350.0) ---
  std::optional<std::uint64_t> opt_uint(std::string_view key, std::uint64_t min,
                                        std::uint64_t max = std::numeric_limits<std::uint64_t>::max()) const {
    const toml::node* n = t_.get(key);
    if (!n) return std::nullopt;
    const std::string need = min == 0   ? "must be a non-negative integer"
                             : min == 1 ? "must be a positive integer"
                                        : "must be an integer >= " + std::to_string(min);
    if (n->is_floating_point()) fail(key, "must be an integer");
    auto i = n->as_integer();
    if (!i) fail(key, "must be an integer, not " + type_name(*n));
    if (i->get() < 0 || static_cast<std::uint64_t>(i->get()) < min) fail(key, need);
    if (static_cast<std::uint64_t>(i->get()) > max) fail(key, "must be <= " + std::to_string(max));
    return static_cast<std::uint64_t>(i->get());
  }

  std::optional<bool> opt_bool(std::string_view key) const {
    const toml::node* n = t_.get(key);
    if (!n) return std::nullopt;
    auto b = n->as_boolean();
    if (!b) fail(key, "must be true or false, not " + type_name(*n));
    return b->get();
  }

  std::optional<std::string> opt_string(std::string_view key) const {
    const toml::node* n = t_.get(key);
    if (!n) return std::nullopt;
    auto s = n->as_string();
    if (!s) fail(key, "must be a string, not " + type_name(*n));
    return s->get();
  }
  std::string string(std::string_view key) const {
    if (!has(key)) missing(key);
    return *opt_string(key);
  }

  /// Array of exactly `count` finite numbers (integers accepted).
  std::optional<std::vector<double>> opt_numbers(std::string_view key, std::size_t count,
                                                 const std::string& form) const {
    const toml::node* n = t_.get(key);
    if (!n) return std::nullopt;
    auto a = n->as_array();
    const std::string need = "must be an array of " + std::to_string(count) + " numbers " + form;
    if (!a || a->size() != count) fail(key, need);
    std::vector<double> out;
    for (const auto& e : *a) {
      if (auto f = e.as_floating_point())
        out.push_back(f->get());
      else if (auto i = e.as_integer())
        out.push_back(static_cast<double>(i->get()));
      else
        fail(key, need);
      if (!std::isfinite(out.back())) fail(key, "must contain finite numbers");
    }
    return out;
  }
  std::optional<config::Vec3d> opt_vec3(std::string_view key) const {
    auto v = opt_numbers(key, 3, "[x, y, z]");
    if (!v) return std::nullopt;
    return config::Vec3d{(*v)[0], (*v)[1], (*v)[2]};
  }
  config::Vec3d vec3(std::string_view key) const {
    if (!has(key)) missing(key);
    return *opt_vec3(key);
  }
  /// A direction, normalised; zero length is an error.
  config::Vec3d unit_vec3(std::string_view key) const {
    const config::Vec3d v = vec3(key);
    const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(n > 0.0)) fail(key, "must be a non-zero direction");
    return {v[0] / n, v[1] / n, v[2] / n};
  }

 private:
  const std::string& file_;
  const toml::table& t_;
  std::string path_;
  bool array_entry_;
  std::vector<std::string_view> allowed_;
};

class CaseParser {
 public:
  CaseParser(const toml::table& root, std::string file) : root_(root), file_(std::move(file)) {}

  LoadedCase parse() {
    check_top_level();
    cfg_.source_path = file_;
    parse_run();
    parse_contact();
    parse_materials();
    parse_pairs();
    parse_shapes();
    parse_populations();
    parse_insertion();
    parse_drum();
    parse_walls();
    parse_particles();
    parse_sinks();
    parse_bulk_test();
    parse_domain();
    parse_phases();
    parse_output();
    check_something_to_simulate();
    check_unused();
    check_particle_densities();
    check_pairs_complete();
    build_templates();
    resolve_bulk_test();
    check_insertion_feasible();
    check_periodic_cells();
    check_initial_overlaps();
    check_time_step();
    return {std::move(cfg_), std::move(warnings_)};
  }

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

  void check_top_level() const {
    std::vector<std::string_view> all;
    for (auto s : kSingle) all.push_back(s);
    for (auto s : kArrays) all.push_back(s);
    for (auto&& [k, v] : root_) {
      const std::string_view key = k.str();
      const bool single = std::find(std::begin(kSingle), std::end(kSingle), key) != std::end(kSingle);
      const bool array = std::find(std::begin(kArrays), std::end(kArrays), key) != std::end(kArrays);
      if (!single && !array) {
        const bool is_array = v.is_array();
        fail("unknown top-level key " + std::string(is_array ? "[[" : "[") + std::string(key) +
             (is_array ? "]]" : "]") + suggestion(key, all, "", "") + "; known tables: [run], [[material]], " +
             "[[pair]], [[shape]], [[population]], [insertion], [drum], [[wall]], [[particle]], [domain], " +
             "[[phase]], [output], [[sink]], [heap], [bulk_density], [shear_box], [contact]");
      }
      if (single && !v.is_table())
        fail("[" + std::string(key) + "] must be a single table, written [" + std::string(key) + "]");
      if (array && !v.is_array_of_tables())
        fail("[[" + std::string(key) + "]] must be an array of tables, written [[" + std::string(key) +
             "]] (once per entry)");
    }
  }

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

  // ---------------------------------------------------------------- tables
  void parse_run() {
    const toml::table* t = single("run");
    if (!t) fail("[run]: required table is missing (it holds dt_s)");
    Reader r(file_, *t, "[run]", false,
             {"dt_s", "seed", "gravity_m_s2", "allow_large_dt", "allow_initial_overlap", "skin_m", "device",
              "lost_particles", "bounds_min_m", "bounds_max_m"});
    auto& run = cfg_.run;
    if (auto dev = r.opt_string("device")) {
      if (*dev == "cpu") run.device = config::Device::Cpu;
      else if (*dev == "gpu") run.device = config::Device::Gpu;
      else if (*dev == "gpu-emulated") run.device = config::Device::GpuEmulated;
      else r.fail("device", "must be \"cpu\", \"gpu\" or \"gpu-emulated\"");
    }
    if (auto lp = r.opt_string("lost_particles")) {
      if (*lp == "remove") run.remove_lost_particles = true;
      else if (*lp != "stop") r.fail("lost_particles", "must be \"stop\" (default) or \"remove\"");
    }
    run.bounds_min_m = r.opt_vec3("bounds_min_m");
    run.bounds_max_m = r.opt_vec3("bounds_max_m");
    if (run.bounds_min_m.has_value() != run.bounds_max_m.has_value())
      r.fail(run.bounds_min_m ? "bounds_min_m" : "bounds_max_m", "bounds_min_m and bounds_max_m go together");
    if (run.bounds_min_m)
      for (int k = 0; k < 3; ++k)
        if (!((*run.bounds_min_m)[k] < (*run.bounds_max_m)[k]))
          r.fail("bounds_max_m", "must exceed bounds_min_m on every axis");
    run.dt_s = r.real("dt_s", kPositive);
    run.seed = r.opt_uint("seed", 0).value_or(1);
    if (auto g = r.opt_vec3("gravity_m_s2")) run.gravity_m_s2 = *g;
    run.allow_large_dt = r.opt_bool("allow_large_dt").value_or(false);
    run.allow_initial_overlap = r.opt_bool("allow_initial_overlap").value_or(false);
    run.skin_m = r.opt_real("skin_m", kPositive);
  }

  void parse_contact() {
    const toml::table* t = single("contact");
    if (!t) return;
    Reader r(file_, *t, "[contact]", false, {"wall_rolling_reference", "tangential_reduce"});
    cfg_.contact.tangential_reduce = r.opt_bool("tangential_reduce").value_or(false);
    if (auto ref = r.opt_string("wall_rolling_reference")) {
      if (*ref == "wall") cfg_.contact.wall_rolling_reference = config::WallRollingReference::Wall;
      else if (*ref == "lab") cfg_.contact.wall_rolling_reference = config::WallRollingReference::Lab;
      else r.fail("wall_rolling_reference", "must be \"wall\" (relative to the wall) or \"lab\" (LIGGGHTS 3.8.0)");
    }
  }

  void parse_materials() {
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

  void parse_pairs() {
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

  void parse_shapes() {
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

  void parse_populations() {
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

  void parse_insertion() {
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
  void parse_insertion_region(const Reader& r, config::Insertion& ins) const {
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

  void parse_drum() {
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

  void parse_walls() {
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

  void parse_sinks() {
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

  // ---------------------------------------------------------------- bulk tests (issue 9)
  const char* bulk_block() const {
    for (const char* b : {"heap", "bulk_density", "shear_box"})
      if (single(b)) return b;
    return nullptr;
  }

  // Expands [heap], [bulk_density] or [shear_box] into walls, a sink, the insertion region and
  // the phases. y is up; gravity must point along -y. Default dimensions: docs/calibration.md.
  void parse_bulk_test() {
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
    auto read_rest = [&](const Reader& r) {
      b.rest_fraction = r.real_or("rest_fraction", b.rest_fraction, kPositive);
      b.rest_hold_s = r.real_or("rest_hold_s", b.rest_hold_s, kPositive);
      b.max_fill_s = r.real_or("max_fill_s", b.max_fill_s, kPositive);
      b.max_rest_s = r.real_or("max_rest_s", b.max_rest_s, kPositive);
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
      if (r.node("sectors")) {
        const double k = r.real_or("sectors", 8.0, kPositive);
        if (!(k >= 4.0 && k <= 8.0 && k == std::floor(k)))
          r.fail("sectors", "must be a whole number from 4 to 8 (vertical half-planes of the surface fit, SPEC 7)");
        b.sectors = static_cast<std::size_t>(k);
      }
      read_rest(r);
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
      read_rest(r);
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
      read_rest(r);
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
  void resolve_bulk_test() {
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

  void parse_particles() {
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

  void parse_domain() {
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

  void parse_phases() {
    const auto list = entries("phase");
    if (cfg_.bulk_test) {
      if (!list.empty()) fail(std::string("[[phase]]: the [") + bulk_block() + "] test defines its own phases (fill, lift or gate, rest); remove the [[phase]] entries");
      return;
    }
    if (list.empty()) fail("[[phase]]: at least one phase is required (name and steps, duration_s or revolutions)");
    for (std::size_t i = 0; i < list.size(); ++i) {
      Reader r(file_, *list[i], entry_path("phase", i, name_label(*list[i])), true,
               {"name", "steps", "duration_s", "revolutions", "until_mean_kinetic_energy_j", "max_duration_s",
                "min_duration_s", "settle_hold_s", "settle_energy", "rotate"});
      config::Phase p;
      p.name = r.string("name");
      if (p.name.empty()) r.fail("name", "must not be empty");
      const char* lengths[] = {"steps", "duration_s", "revolutions", "until_mean_kinetic_energy_j"};
      std::vector<std::string_view> given;
      for (auto k : lengths)
        if (r.has(k)) given.push_back(k);
      if (given.empty())
        r.missing("steps", " (a phase needs one of steps, duration_s, revolutions or until_mean_kinetic_energy_j)");
      if (given.size() > 1)
        r.fail(given[1], "a phase takes exactly one of steps, duration_s, revolutions, until_mean_kinetic_energy_j "
                         "(also given: " + std::string(given[0]) + ")");
      const bool settle = given[0] == "until_mean_kinetic_energy_j";
      if (!settle)
        for (auto k : {"max_duration_s", "min_duration_s", "settle_hold_s", "settle_energy"})
          if (r.has(k)) r.fail(k, "only used with until_mean_kinetic_energy_j (a settle criterion)");
      if (r.has("steps")) {
        p.length = config::PhaseLength::Steps;
        p.steps = *r.opt_uint("steps", 1);
      } else if (r.has("duration_s")) {
        p.length = config::PhaseLength::Duration;
        p.duration_s = r.real("duration_s", kPositive);
      } else if (r.has("revolutions")) {
        p.length = config::PhaseLength::Revolutions;
        p.revolutions = r.real("revolutions", kPositive);
        if (!cfg_.drum) r.fail("revolutions", "needs a [drum]");
        if (cfg_.drum->rpm == 0.0) r.fail("revolutions", "needs a turning drum ([drum].rpm = 0)");
      } else {
        // Settle criterion: stored as a Duration phase capped at max_duration_s, so that the
        // phase length is always well defined; the criterion may end it earlier.
        p.until_mean_kinetic_energy_j = r.real("until_mean_kinetic_energy_j", kPositive);
        if (!r.has("max_duration_s")) r.missing("max_duration_s", " (the cap of a settle criterion)");
        p.max_duration_s = r.real("max_duration_s", kPositive);
        p.min_duration_s = r.real_or("min_duration_s", 0.0, kNonNegative);
        p.settle_hold_s = r.real_or("settle_hold_s", p.settle_hold_s, kPositive);
        if (p.min_duration_s > *p.max_duration_s) r.fail("min_duration_s", "must not exceed max_duration_s");
        if (auto e = r.opt_string("settle_energy")) {
          if (*e == "translational") p.translational_criterion = true;
          else if (*e != "total") r.fail("settle_energy", "must be \"total\" (default) or \"translational\"");
        }
        p.length = config::PhaseLength::Duration;
        p.duration_s = *p.max_duration_s;
      }
      p.rotate = r.opt_bool("rotate").value_or(p.length == config::PhaseLength::Revolutions);
      if (p.length == config::PhaseLength::Revolutions && !p.rotate)
        r.fail("rotate", "a phase given in revolutions turns the drum");
      if (p.rotate && !cfg_.drum) r.fail("rotate", "there is no [drum] to rotate");
      cfg_.phases.push_back(p);
    }
  }

  void parse_output() {
    const toml::table* t = single("output");
    if (!t) return;
    Reader r(file_, *t, "[output]", false,
             {"sample_hz", "snapshot_every_s", "checkpoint_every_s", "trace", "frame_every_s", "frame_size_px"});
    auto& o = cfg_.output;
    o.sample_hz = r.real_or("sample_hz", o.sample_hz, kPositive);
    o.snapshot_every_s = r.opt_real("snapshot_every_s", kPositive);
    o.checkpoint_every_s = r.opt_real("checkpoint_every_s", kPositive);
    o.trace = r.opt_bool("trace").value_or(false);
    o.frame_every_s = r.opt_real("frame_every_s", kPositive);
    o.frame_size_px = static_cast<std::uint32_t>(r.opt_uint("frame_size_px", 64, 16384).value_or(o.frame_size_px));
  }

  // ---------------------------------------------------------------- cross checks
  void check_something_to_simulate() const {
    if (!cfg_.drum && cfg_.particles.empty() && !cfg_.insertion)
      fail("nothing to simulate: give a [drum] with [insertion] and [[population]], or [[particle]] entries");
    if (!cfg_.populations.empty() && !cfg_.insertion)
      fail("[[population]]: populations are only used by [insertion], which is missing");
  }

  void check_unused() {
    std::set<std::size_t> used;
    for (const auto& p : cfg_.populations) used.insert(p.shape);
    for (const auto& p : cfg_.particles) used.insert(p.shape);
    for (std::size_t s = 0; s < cfg_.shapes.size(); ++s)
      if (!used.count(s)) warn(entry_path("shape", s, cfg_.shapes[s].name) + " is not used");
  }

  std::set<std::size_t> particle_materials() const {
    std::set<std::size_t> m;
    for (const auto& p : cfg_.populations) m.insert(p.material);
    for (const auto& p : cfg_.particles) m.insert(p.material);
    return m;
  }

  void check_particle_densities() const {
    for (std::size_t m : particle_materials())
      if (!cfg_.materials[m].density_kg_m3)
        fail(entry_path("material", m, mat_name(m)) +
             " .density_kg_m3: required key is missing (the material is used by particles)");
  }

  void check_pairs_complete() const {
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

  void build_templates() {
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

  void check_insertion_feasible() const {
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
  void check_region_feasible() const {
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

  void check_periodic_cells() const {
    // The cell list needs at least 3 cells across a periodic length, a cell being at least the
    // largest sphere diameter plus the skin (so that no pair is seen twice through the boundary).
    double dmax = 0.0, rmin = kInf;
    for (const auto& [s, t] : templates_) {
      dmax = std::max(dmax, 2.0 * t.max_radius_m);
      rmin = std::min(rmin, t.min_radius_m);
    }
    const double skin = cfg_.run.skin_m.value_or(0.5 * rmin);  // as resolved_skin_m(), without rebuilding templates
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

  void check_initial_overlaps() const {
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

  void check_time_step() {
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
};

/// Messages quote the case's own text (TOML errors echo the bytes read, names may hold escaped
/// newlines): control characters are written as escapes so that every error stays one line
/// (issue 10, item 8: found by fuzzing).
std::string one_line(std::string_view m) {
  std::string out;
  for (const char c : m) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '\n') out += "\\n";
    else if (c == '\r') out += "\\r";
    else if (c == '\t') out += "\\t";
    else if (u < 0x20 || u == 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", u);
      out += buf;
    } else out += c;
  }
  return out;
}

}  // namespace

LoadedCase parse_case(std::string_view toml_text, const std::string& source_name) {
  toml::table root;
  try {
    root = toml::parse(toml_text, source_name);
  } catch (const toml::parse_error& e) {
    const auto& b = e.source().begin;
    throw Error(one_line(source_name + ":" + std::to_string(b.line) + ":" + std::to_string(b.column) +
                         ": TOML syntax error: " + std::string(e.description())));
  }
  try {
    return CaseParser(root, source_name).parse();
  } catch (const Error& e) {
    throw Error(one_line(e.what()));
  }
}

LoadedCase load_case(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw Error(path + ": case file not found");
  if (std::filesystem::is_directory(path, ec)) throw Error(path + ": is a directory, not a case file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open the case file: " + std::strerror(errno));
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw Error(path + ": cannot read the case file");
  return parse_case(ss.str(), path);
}

}  // namespace biodem::io
