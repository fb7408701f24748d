// `biodem check CASE`: parse and validate a case without running it; warnings go to stderr
// (prefixed "warning: "), the resolved case and its derived quantities to stdout. A calibration
// file (CALIB.toml: [[test]] and [[parameter]] tables) is checked as `calibrate` checks it: its
// tests' cases validated with every parameter at its lower and at its upper bound.
#include <toml++/toml.h>

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <string>
#include <utility>
#include <vector>

#include "calib/calib_file.hpp"
#include "case_file/case_parser.hpp"
#include "commands.hpp"
#include "core/error.hpp"
#include "output/case_report.hpp"

namespace biodem::cli {
namespace {

// What the file holds at its top level, when it parses as TOML (else the case parser says why).
struct Kind {
  bool calibration = false;  // [[test]] and [[parameter]]
  bool fragment = false;     // no [run], or no [[phase]] and no bulk test (a calibration's base file)
};

Kind peek(const std::string& path) {
  Kind k;
  try {
    const toml::table t = toml::parse_file(path);
    k.calibration = t.contains("test") && t.contains("parameter");
    const bool bulk = t.contains("heap") || t.contains("bulk_density") || t.contains("shear_box");
    k.fragment = !t.contains("run") || (!t.contains("phase") && !bulk);
  } catch (const std::exception&) {
  }
  return k;
}

int check_calibration(const std::string& path) {
  const calib::CalibConfig c = calib::load_calib(path);  // biodem::Error -> main prints it, exit 2
  std::cout << "calibration file: " << c.source_path << "\n";
  std::cout << "search: population " << c.population << ", generations " << c.generations << ", seed " << c.seed << "\n";
  std::cout << "tests (each case checked with every parameter at its lower and at its upper bound):\n";
  for (const auto& t : c.tests) {
    std::cout << "  " << t.name << (t.drum ? " (drum test)" : "");
    if (!t.seeds.empty()) std::cout << ", " << t.seeds.size() << " seeds";
    std::cout << "\n";
  }
  std::cout << "parameters:\n";
  for (const auto& p : c.parameters) {
    std::cout << "  " << p.name << " in [" << p.lower << ", " << p.upper << "]:";
    for (const auto& k : p.keys) {
      std::cout << " " << k.path;
      if (k.factor != 1.0) std::cout << " x " << k.factor;
    }
    std::cout << "\n";
  }
  std::cout << "targets:\n";
  for (const auto& t : c.targets) std::cout << "  " << t.response << " = " << t.value << " " << t.unit << "\n";
  for (const auto* o : {&c.o1, &c.o2}) {
    std::cout << (o == &c.o1 ? "o1" : "o2") << ": weighted mean of the relative errors of";
    for (std::size_t i = 0; i < o->responses.size(); ++i) std::cout << " " << o->responses[i] << " (" << o->weights[i] << ")";
    std::cout << "\n";
  }
  std::cout << std::flush;
  return 0;
}

// The calibration files beside a case or base file of a [[test]] (in its folder) that use it,
// with the names of the tests that do, sorted by path.
std::vector<std::pair<std::string, std::string>> calibrations_using(const std::string& path) {
  namespace fs = std::filesystem;
  std::vector<std::pair<std::string, std::string>> found;
  std::error_code ec;
  const fs::path me = fs::weakly_canonical(fs::absolute(path, ec), ec);
  const fs::path dir = fs::path(path).parent_path().empty() ? fs::path(".") : fs::path(path).parent_path();
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_regular_file(ec) && e.path().extension() == ".toml") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  for (const auto& f : files) {
    try {
      const toml::table t = toml::parse_file(f.string());
      const toml::array* tests = t["test"].as_array();
      if (!tests || !t.contains("parameter")) continue;
      std::string names;
      int count = 0;
      for (const auto& node : *tests) {
        const toml::table* test = node.as_table();
        if (!test) continue;
        for (const char* key : {"case", "base"}) {
          const auto file = (*test)[key].value<std::string>();
          if (!file) continue;
          const fs::path used = fs::weakly_canonical(fs::absolute(f.parent_path() / *file, ec), ec);
          if (used == me) {
            const std::string name = (*test)["name"].value_or(std::string("?"));
            if (names.find("'" + name + "'") == std::string::npos) {
              names += std::string(names.empty() ? "" : ", ") + "'" + name + "'";
              ++count;
            }
          }
        }
      }
      if (count) found.emplace_back(f.string(), (count == 1 ? "test " : "tests ") + names);
    } catch (const std::exception&) {
    }
  }
  return found;
}

}  // namespace

Action register_check(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "check", "Validate a case and print derived quantities (n_spb, clump length, volume, d_eq, mass, inertia, "
               "Rayleigh time, dt as % of it, particle count for a fill fraction) without running; a calibration "
               "file (CALIB.toml) is checked as calibrate checks it");
  static std::string case_path;
  sub->add_option("CASE", case_path, "case file or calibration file (TOML)")->required();
  return [] {
    const Kind kind = peek(case_path);
    if (kind.calibration) return check_calibration(case_path);
    try {
      const case_file::LoadedCase loaded = case_file::load_case(case_path);  // biodem::Error -> main prints it, exit 2
      for (const auto& w : loaded.warnings) std::cerr << "warning: " << w << "\n";
      std::cout << output::describe_case(loaded.config) << std::flush;
    } catch (const Error& e) {
      // A calibration's case file alone has no [run], its base file no phases (calibrate merges
      // the two): it is checked through the calibration files beside it that use it, or, without
      // one, the error points to them.
      if (!kind.fragment) throw;
      const auto users = calibrations_using(case_path);
      if (users.empty())
        throw Error(std::string(e.what()) +
                    " (if this is a [[test]]'s case or base file of a calibration, it is checked through its "
                    "calibration file: biodem check CALIB.toml)");
      for (const auto& [calib_path, tests] : users) {
        std::cout << case_path << ": not a case by itself, but a file of " << tests << " of the calibration "
                  << calib_path << ", checked through it:\n";
        check_calibration(calib_path);  // biodem::Error -> main prints it, exit 2
      }
    }
    return 0;
  };
}

}  // namespace biodem::cli
