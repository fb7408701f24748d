// `biodem analyze`: placeholder until the analysis work lands.
#include <iostream>
#include <string>
#include <vector>

#include "commands.hpp"

namespace biodem::cli {

Action register_analyze(CLI::App& app) {
  auto* sub = app.add_subcommand("analyze", "analyze (not yet available)");
  static std::vector<std::string> args;
  sub->add_option("ARGS", args, "arguments");
  sub->allow_extras();
  return [] {
    std::cerr << "biodem: error: analyze is not implemented yet in this version\n";
    return 2;
  };
}

}  // namespace biodem::cli
