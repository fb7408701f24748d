#include "calib/calib_file.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "core/error.hpp"
#include "case_file/case_parser.hpp"

namespace biodem::calib {
namespace {

namespace fs = std::filesystem;

// Which bulk test produces which response (run_driver.cpp, write_responses).
const std::vector<std::pair<std::string, std::vector<std::string>>> kProduces = {
    {"heap", {"angle_of_repose_deg", "heap_height_m", "heap_base_radius_m"}},
    {"bulk_density", {"bulk_density_kg_m3", "solid_fraction", "core_solid_fraction"}},
    {"shear_box", {"retainment_ratio"}},
};
const char* const kBulkBlocks[] = {"heap", "bulk_density", "shear_box"};

// The responses a test produces: a bulk test's (kProduces), a drum test's (drum_test.hpp).
bool produces(const CalibTest& test, const std::string& response) {
  if (test.drum) {
    const auto& n = drum_response_names();
    return std::find(n.begin(), n.end(), response) != n.end();
  }
  for (const auto& [block, responses] : kProduces)
    if (test.case_text.find("[" + block + "]") != std::string::npos &&
        std::find(responses.begin(), responses.end(), response) != responses.end())
      return true;
  return false;
}
// The unit of each response, as its test writes it in responses.csv (bulk_responses.cpp): a
// target is a value in that unit, so a target in another unit would be compared with numbers
// it does not describe.
const std::map<std::string, std::string> kUnit = {
    {"angle_of_repose_deg", "deg"}, {"heap_height_m", "m"},        {"heap_base_radius_m", "m"},
    {"bulk_density_kg_m3", "kg/m3"}, {"solid_fraction", "-"},      {"core_solid_fraction", "-"},
    {"retainment_ratio", "-"},
};
// The largest NSGA-II population (evaluations per generation); more is a mistake of the file.
constexpr std::uint64_t kMostPopulation = 100000;
// The most seeds of one [[test]] (a mean over more runs than this is a campaign of its own).
constexpr std::size_t kMostSeeds = 64;
const std::vector<std::string> kPairKeys = {"restitution", "sliding_friction", "rolling_friction",
                                            "cohesion_energy_density_j_m3"};

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot read");
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

std::vector<std::string> split(const std::string& s, char c) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string p;
  while (std::getline(ss, p, c)) out.push_back(p);
  return out;
}

class CalibParser {
 public:
  CalibParser(std::string path) : path_(std::move(path)) {}

  CalibConfig parse() {
    toml::table root;
    try {
      root = toml::parse(slurp(path_), path_);
    } catch (const toml::parse_error& e) {
      fail(std::string("TOML syntax error: ") + std::string(e.description()));
    }
    for (auto&& [k, v] : root)
      if (k.str() != "campaign" && k.str() != "test" && k.str() != "target" && k.str() != "parameter" &&
          k.str() != "objectives")
        fail("unknown top-level key " + std::string(k.str()) +
             "; known: [campaign], [[test]], [[target]], [[parameter]], [objectives]");
    c_.source_path = path_;
    campaign(root);
    tests(root);
    targets(root);
    parameters(root);
    objectives(root);
    check_cases();
    return c_;
  }

 private:
  [[noreturn]] void fail(const std::string& m) const { throw Error(path_ + ": " + m); }

  void only(const toml::table& t, const std::string& where, std::initializer_list<std::string_view> keys) const {
    for (auto&& [k, v] : t)
      if (std::find(keys.begin(), keys.end(), k.str()) == keys.end())
        fail("unknown key " + where + "." + std::string(k.str()));
  }
  double real(const toml::table& t, const std::string& where, const char* key) const {
    const auto* n = t.get(key);
    if (!n) fail(where + "." + key + ": required key is missing");
    if (auto f = n->as_floating_point()) {
      if (!std::isfinite(f->get())) fail(where + "." + key + ": must be a finite number (nan and inf are not)");
      return f->get();
    }
    if (auto i = n->as_integer()) return static_cast<double>(i->get());
    fail(where + "." + key + ": must be a number");
  }
  std::string str(const toml::table& t, const std::string& where, const char* key) const {
    const auto* n = t.get(key);
    if (!n) fail(where + "." + key + ": required key is missing");
    if (auto s = n->as_string()) return s->get();
    fail(where + "." + key + ": must be a string");
  }
  std::uint64_t uint(const toml::table& t, const std::string& where, const char* key, std::uint64_t def) const {
    const auto* n = t.get(key);
    if (!n) return def;
    auto i = n->as_integer();
    if (!i || i->get() < 0) {
      std::string value;  // (the value as written, when it is a number)
      if (i) value = " = " + std::to_string(i->get());
      if (auto f = n->as_floating_point()) {
        char b[32];
        std::snprintf(b, sizeof b, " = %g", f->get());
        value = b;
      }
      fail(where + "." + key + value + ": must be a non-negative integer (written without a decimal point)");
    }
    return static_cast<std::uint64_t>(i->get());
  }
  std::vector<const toml::table*> entries(const toml::table& root, const char* name) const {
    std::vector<const toml::table*> out;
    if (const auto* a = root.get_as<toml::array>(name))
      for (const auto& e : *a) {
        if (!e.as_table()) fail(std::string("[[") + name + "]] must be an array of tables");
        out.push_back(e.as_table());
      }
    else if (root.contains(name))
      fail(std::string("[[") + name + "]] must be an array of tables, written [[" + name + "]]");
    return out;
  }

  void campaign(const toml::table& root) {
    const auto* t = root.get_as<toml::table>("campaign");
    if (!t) return;
    only(*t, "[campaign]", {"population", "generations", "seed"});
    c_.population = uint(*t, "[campaign]", "population", 8);
    c_.generations = uint(*t, "[campaign]", "generations", 2);
    c_.seed = uint(*t, "[campaign]", "seed", 1);
    if (c_.population < 8 || c_.population % 4 != 0)
      fail("[campaign].population = " + std::to_string(c_.population) +
           ": NSGA-II needs a multiple of 4, at least 8");
    if (c_.population > kMostPopulation)
      fail("[campaign].population = " + std::to_string(c_.population) + ": at most " + std::to_string(kMostPopulation));
    if (c_.generations < 1) fail("[campaign].generations = 0: at least 1");
    // NSGA-II (pagmo) takes a 32-bit seed: a larger one would give the search of seed mod 2^32.
    if (c_.seed > 0xffffffffu)
      fail("[campaign].seed = " + std::to_string(c_.seed) + ": at most 4294967295 (the search's seed is 32 bits)");
  }

  void tests(const toml::table& root) {
    const auto list = entries(root, "test");
    if (list.empty()) fail("[[test]]: at least one bulk-test case is required");
    std::set<std::string> names;
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string w = "[[test]] #" + std::to_string(i + 1);
      only(*list[i], w, {"name", "case", "base", "min_drop_deg", "skip_s", "skip_rev", "seeds"});
      CalibTest t;
      t.name = str(*list[i], w, "name");
      if (t.name.empty() || t.name == "." || t.name == ".." || t.name.find_first_of("/ \\") != std::string::npos)
        fail(w + ".name = \"" + t.name + "\": a non-empty name without slashes or spaces");
      if (!names.insert(t.name).second) fail(w + ".name = \"" + t.name + "\": given twice");
      const fs::path dir = fs::path(path_).parent_path();
      t.case_path = (dir / str(*list[i], w, "case")).string();
      if (!fs::exists(t.case_path)) fail(w + ".case: " + t.case_path + " does not exist");
      toml::table tc;
      try {
        tc = toml::parse(slurp(t.case_path), t.case_path);
      } catch (const toml::parse_error& e) {
        fail(w + ".case: " + t.case_path + ": TOML syntax error: " + std::string(e.description()));
      }
      if (list[i]->contains("base")) {  // tables of the base case that the test case lacks
        const std::string base = (dir / str(*list[i], w, "base")).string();
        if (!fs::exists(base)) fail(w + ".base: " + base + " does not exist");
        toml::table tb;
        try {
          tb = toml::parse(slurp(base), base);
        } catch (const toml::parse_error& e) {
          fail(w + ".base: " + base + ": TOML syntax error: " + std::string(e.description()));
        }
        for (auto&& [k, v] : tb)
          if (!tc.contains(k.str())) tc.insert(k.str(), v);
      }
      // A drum test: a [drum] and no bulk-test block; its analysis options (analyze's).
      const bool bulk = std::any_of(std::begin(kBulkBlocks), std::end(kBulkBlocks),
                                    [&](const char* b) { return tc.contains(b); });
      if (tc.contains("drum") && !bulk) {
        DrumAnalysis a;
        auto positive = [&](const char* key, bool zero_ok) -> std::optional<double> {
          if (!list[i]->contains(key)) return std::nullopt;
          const double v = real(*list[i], w, key);
          if (!(zero_ok ? v >= 0.0 : v > 0.0) || !std::isfinite(v))
            fail(w + "." + key + " = " + std::to_string(v) + ": must be " + (zero_ok ? "at least 0" : "positive"));
          return v;
        };
        a.min_drop_deg = positive("min_drop_deg", false);
        a.skip_s = positive("skip_s", true);
        a.skip_rev = positive("skip_rev", true);
        if (a.skip_s && a.skip_rev) fail(w + ": skip_s and skip_rev both given; give one");
        t.drum = a;
      } else {
        for (const char* key : {"min_drop_deg", "skip_s", "skip_rev"})
          if (list[i]->contains(key))
            fail(w + "." + key + ": an analysis option of drum tests; case " + t.case_path +
                 " is not a drum test (it needs a [drum] and no [heap], [bulk_density] or [shear_box])");
      }
      if (list[i]->contains("seeds")) {  // one run per seed, the responses their mean
        const auto* a = list[i]->get("seeds")->as_array();
        if (!a || a->empty() || a->size() > kMostSeeds)
          fail(w + ".seeds: an array of 1 to " + std::to_string(kMostSeeds) + " seeds (integers), e.g. [1, 2, 3]");
        for (const auto& e : *a) {
          const auto* n = e.as_integer();
          if (!n || n->get() < 0)
            fail(w + ".seeds: each seed must be a non-negative integer (written without a decimal point)");
          const auto s = static_cast<std::uint64_t>(n->get());
          if (std::find(t.seeds.begin(), t.seeds.end(), s) != t.seeds.end())
            fail(w + ".seeds: seed " + std::to_string(s) + " given twice");
          t.seeds.push_back(s);
        }
      }
      std::ostringstream os;
      os << tc;
      t.case_text = os.str();
      c_.tests.push_back(t);
    }
  }

  void targets(const toml::table& root) {
    const auto list = entries(root, "target");
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string w = "[[target]] #" + std::to_string(i + 1);
      only(*list[i], w, {"response", "value", "unit"});
      CalibTarget t;
      t.response = str(*list[i], w, "response");
      t.value = real(*list[i], w, "value");
      t.unit = str(*list[i], w, "unit");
      if (t.value == 0.0) fail(w + ".value = 0: a relative error needs a non-zero target");
      for (const auto& earlier : c_.targets)
        if (earlier.response == t.response)
          fail(w + ".response = \"" + t.response + "\": has a target already (one [[target]] per response)");
      bool produced = false, by_drum = false;
      for (const auto& test : c_.tests)
        if (produces(test, t.response)) {
          produced = true;
          by_drum = by_drum || test.drum.has_value();
        }
      if (!produced) fail(w + ".response = \"" + t.response + "\": no [[test]] case measures it");
      const auto u = kUnit.find(t.response);
      const std::string unit = u != kUnit.end() ? u->second : by_drum ? drum_response_unit(t.response) : "";
      if (!unit.empty() && t.unit != unit)
        fail(w + ".unit = \"" + t.unit + "\": " + t.response + " is measured in \"" + unit +
             "\"; give the target's value in it");
      c_.targets.push_back(t);
    }
  }

  void parameters(const toml::table& root) {
    const auto list = entries(root, "parameter");
    if (list.empty()) fail("[[parameter]]: at least one parameter is required");
    std::set<std::string> names;
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string w = "[[parameter]] #" + std::to_string(i + 1);
      only(*list[i], w, {"name", "lower", "upper", "keys", "factors"});
      CalibParameter p;
      p.name = str(*list[i], w, "name");
      if (p.name.empty() || p.name.find_first_of(", ") != std::string::npos)
        fail(w + ".name: a non-empty name without commas or spaces");
      if (!names.insert(p.name).second) fail(w + ".name = \"" + p.name + "\": given twice");
      // The evaluation files have a column per parameter beside these: a parameter of the same
      // name would be two columns of one name, and --evaluate would read the other one.
      for (const char* fixed : {"generation", "index", "o1", "o2", "wall_s"})
        if (p.name == fixed) fail(w + ".name = \"" + p.name + "\": is a column of the evaluation files; choose another name");
      for (const auto& t : c_.targets)
        if (p.name == t.response)
          fail(w + ".name = \"" + p.name + "\": is a response's column of the evaluation files; choose another name");
      p.lower = real(*list[i], w, "lower");
      p.upper = real(*list[i], w, "upper");
      if (!(p.upper > p.lower)) fail(w + ".upper: must exceed lower");
      const auto* keys = list[i]->get_as<toml::array>("keys");
      if (!keys || keys->empty()) fail(w + ".keys: required, a non-empty array of case keys (\"pair.A.B.key\")");
      const auto* factors = list[i]->get_as<toml::array>("factors");
      if (factors && factors->size() != keys->size()) fail(w + ".factors: one factor per key");
      for (std::size_t k = 0; k < keys->size(); ++k) {
        CalibKey key;
        const auto* s = (*keys)[k].as_string();
        if (!s) fail(w + ".keys: strings");
        key.path = s->get();
        if (factors) {
          const auto& f = (*factors)[k];
          if (auto d = f.as_floating_point()) key.factor = d->get();
          else if (auto n = f.as_integer()) key.factor = static_cast<double>(n->get());
          else fail(w + ".factors: numbers");
          if (!(key.factor > 0.0)) fail(w + ".factors: must be positive");
        }
        const auto parts = split(key.path, '.');
        if (parts.size() != 4 || parts[0] != "pair" ||
            std::find(kPairKeys.begin(), kPairKeys.end(), parts[3]) == kPairKeys.end())
          fail(w + ".keys: \"" + key.path +
               "\": unknown parameter path; use pair.<material>.<material>.<restitution|sliding_friction|"
               "rolling_friction|cohesion_energy_density_j_m3>");
        const double lo = p.lower * key.factor, hi = p.upper * key.factor;
        if (parts[3] != "restitution" && lo < 0.0)
          fail(w + ".lower = " + std::to_string(p.lower) + ": " + parts[3] + " cannot be negative");
        if (parts[3] == "restitution" && (lo <= 0.0 || hi > 1.0))
          fail(w + ".lower/upper: restitution must stay in (0, 1]");
        // (pair.A.B.k and pair.B.A.k are one key)
        const auto same = [&](const CalibKey& other) {
          const auto o = split(other.path, '.');
          return o[3] == parts[3] && ((o[1] == parts[1] && o[2] == parts[2]) || (o[1] == parts[2] && o[2] == parts[1]));
        };
        for (const auto& q : c_.parameters)
          for (const auto& other : q.keys)
            if (same(other))
              fail(w + ".keys: \"" + key.path + "\" is set by parameter \"" + q.name + "\" already (one parameter per key)");
        for (const auto& other : p.keys)
          if (same(other)) fail(w + ".keys: \"" + key.path + "\" given twice");
        p.keys.push_back(key);
      }
      c_.parameters.push_back(p);
    }
  }

  void objectives(const toml::table& root) {
    // Defaults: SPEC 7's O1 (angle of repose and bulk density) and O2 (retainment ratio).
    c_.o1 = {{"angle_of_repose_deg", "bulk_density_kg_m3"}, {1.0, 1.0}};
    c_.o2 = {{"retainment_ratio"}, {1.0}};
    if (const auto* t = root.get_as<toml::table>("objectives")) {
      only(*t, "[objectives]", {"o1", "o1_weights", "o2", "o2_weights"});
      auto read = [&](const char* key, const char* wkey, CalibObjective& o) {
        if (const auto* a = t->get_as<toml::array>(key)) {
          o.responses.clear();
          for (const auto& e : *a) {
            if (!e.as_string()) fail(std::string("[objectives].") + key + ": strings (response names)");
            o.responses.push_back(e.as_string()->get());
          }
          o.weights.assign(o.responses.size(), 1.0);
        }
        if (const auto* a = t->get_as<toml::array>(wkey)) {
          if (a->size() != o.responses.size()) fail(std::string("[objectives].") + wkey + ": one weight per response");
          for (std::size_t k = 0; k < a->size(); ++k) {
            const auto& e = (*a)[k];
            double v = e.as_floating_point() ? e.as_floating_point()->get()
                       : e.as_integer()      ? static_cast<double>(e.as_integer()->get())
                                             : -1.0;
            if (!(v >= 0.0) || !std::isfinite(v)) fail(std::string("[objectives].") + wkey + ": non-negative finite numbers");
            o.weights[k] = v;
          }
          if (std::none_of(o.weights.begin(), o.weights.end(), [](double v) { return v > 0.0; }))
            fail(std::string("[objectives].") + wkey + ": at least one weight must be positive");
        }
        if (o.responses.empty()) fail(std::string("[objectives].") + key + ": at least one response");
      };
      read("o1", "o1_weights", c_.o1);
      read("o2", "o2_weights", c_.o2);
    }
    for (const auto* o : {&c_.o1, &c_.o2})
      for (const auto& r : o->responses)
        if (std::none_of(c_.targets.begin(), c_.targets.end(), [&](const CalibTarget& t) { return t.response == r; }))
          fail("[[target]]: missing target for response \"" + r + "\" (used by " +
               (o == &c_.o1 ? "o1" : "o2") + ")");
  }

  // Every test case, with every parameter at its lower and at its upper bound, must be a valid
  // case that holds every key the parameters name.
  void check_cases() const {
    for (const auto& t : c_.tests) {
      for (const auto& p : c_.parameters)
        for (const auto& k : p.keys) {
          const auto parts = split(k.path, '.');
          if (t.case_text.find(parts[1]) == std::string::npos || !has_pair(t.case_text, parts[1], parts[2]))
            fail("[[parameter]] \"" + p.name + "\" key \"" + k.path + "\": test \"" + t.name +
                 "\" has no [[pair]] of materials " + parts[1] + " and " + parts[2]);
        }
      for (int end = 0; end < 2; ++end) {
        std::vector<double> x;
        for (const auto& p : c_.parameters) x.push_back(end ? p.upper : p.lower);
        bool rotates = false;
        try {
          const auto loaded = case_file::parse_case(apply_parameters(c_, t, x), t.case_path);
          rotates = std::any_of(loaded.config.phases.begin(), loaded.config.phases.end(),
                                [](const config::Phase& ph) { return ph.rotate; }) &&
                    loaded.config.drum && loaded.config.drum->rpm != 0.0;
        } catch (const Error& e) {
          fail("[[test]] \"" + t.name + "\" with the parameters at their " + (end ? "upper" : "lower") +
               " bounds: " + e.what());
        }
        if (t.drum && !rotates)
          fail("[[test]] \"" + t.name + "\": a drum test needs a [[phase]] with rotate = true and a [drum].rpm other than 0 (its events are of the turning drum)");
      }
    }
  }

  static bool has_pair(const std::string& text, const std::string& a, const std::string& b) {
    const toml::table t = toml::parse(text);
    if (const auto* pairs = t.get_as<toml::array>("pair"))
      for (const auto& e : *pairs) {
        const auto* m = e.as_table() ? e.as_table()->get_as<toml::array>("materials") : nullptr;
        if (!m || m->size() != 2) continue;
        const auto x = (*m)[0].value_or(std::string()), y = (*m)[1].value_or(std::string());
        if ((x == a && y == b) || (x == b && y == a)) return true;
      }
    return false;
  }

  std::string path_;
  CalibConfig c_;
};

}  // namespace

CalibConfig load_calib(const std::string& path) {
  if (!fs::exists(path)) throw Error(path + ": no such file");
  return CalibParser(path).parse();
}

std::string with_seed(const std::string& case_text, std::uint64_t seed) {
  toml::table t = toml::parse(case_text);
  if (!t.contains("run")) t.insert("run", toml::table{});
  auto* run = t.get_as<toml::table>("run");
  if (!run) throw Error("[run] is not a table: the seed cannot be set");
  run->insert_or_assign("seed", static_cast<std::int64_t>(seed));
  std::ostringstream os;
  os << t;
  return os.str();
}

std::string apply_parameters(const CalibConfig& c, const CalibTest& test, const std::vector<double>& x) {
  toml::table t = toml::parse(test.case_text);
  auto* pairs = t.get_as<toml::array>("pair");
  for (std::size_t k = 0; k < c.parameters.size(); ++k)
    for (const auto& key : c.parameters[k].keys) {
      const auto parts = split(key.path, '.');
      if (!pairs) continue;
      for (auto& e : *pairs) {
        auto* tb = e.as_table();
        const auto* m = tb ? tb->get_as<toml::array>("materials") : nullptr;
        if (!m || m->size() != 2) continue;
        const auto a = (*m)[0].value_or(std::string()), b = (*m)[1].value_or(std::string());
        if ((a == parts[1] && b == parts[2]) || (a == parts[2] && b == parts[1]))
          tb->insert_or_assign(parts[3], x[k] * key.factor);
      }
    }
  std::ostringstream os;
  os << t;
  return os.str();
}

const CalibTarget& target_of(const CalibConfig& c, const std::string& response) {
  for (const auto& t : c.targets)
    if (t.response == response) return t;
  throw Error(c.source_path + ": no target for " + response);
}

}  // namespace biodem::calib
