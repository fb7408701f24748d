// Case file (TOML, SPEC 11) -> config::CaseConfig, with every check a case needs before
// anything is computed (SPEC 10; STYLE.md 6). Two passes:
//   1. table by table: types, ranges, required and unknown keys, references by name;
//   2. across tables: densities of particle materials, completeness of the pair table,
//      insertion feasibility, periodic cell size, initial overlaps of explicit particles, and
//      the time step against the Rayleigh time.
// Every error is one line: "<file>: <table path>.<key> = <value as written>: <reason>".
// The passes are detail::CaseParser (case_parser_detail.hpp): the first in parse_<table>.cpp,
// one file per group of tables, the second in cross_checks.cpp; typed key access in
// toml_reader.hpp.
#include "case_file/case_parser.hpp"

#include <toml++/toml.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "case_file/case_parser_detail.hpp"
#include "core/error.hpp"

namespace biodem::case_file {
namespace {

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

namespace detail {

LoadedCase CaseParser::parse() {
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
  check_output_cadence();
  check_unused();
  check_particle_densities();
  check_pairs_complete();
  build_templates();
  resolve_bulk_test();
  check_insertion_feasible();
  check_periodic_cells();
  check_walls_across_periodic_axes();
  check_particles_inside_bounds();
  check_initial_overlaps();
  check_time_step();
  return {std::move(cfg_), std::move(warnings_)};
}

void CaseParser::check_top_level() const {
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
    const std::string name(key);  // an lvalue: "[" + std::string(key) trips a GCC 12 -Wrestrict false positive
    if (single && !v.is_table()) fail("[" + name + "] must be a single table, written [" + name + "]");
    if (array && !v.is_array_of_tables())
      fail("[[" + name + "]] must be an array of tables, written [[" + name + "]] (once per entry)");
  }
}

}  // namespace detail

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
    return detail::CaseParser(root, source_name).parse();
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

}  // namespace biodem::case_file
