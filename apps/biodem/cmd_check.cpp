// `biodem check CASE` (placeholder until the case parser lands).
#include <iostream>
#include <string>

#include "commands.hpp"

namespace biodem::cli {

Action register_check(CLI::App& app) {
  auto* sub = app.add_subcommand("check", "Validate a case and print derived quantities");
  static std::string case_path;
  sub->add_option("CASE", case_path, "case file (TOML)")->required();
  return [] {
    std::cerr << "biodem: error: check is not implemented yet\n";
    return 2;
  };
}

}  // namespace biodem::cli
