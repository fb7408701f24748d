// `biodem compare`: placeholder until the analysis work lands.
#include <iostream>
#include <string>
#include <vector>

#include "commands.hpp"

namespace biodem::cli {

Action register_compare(CLI::App& app) {
  auto* sub = app.add_subcommand("compare", "compare (not yet available)");
  static std::vector<std::string> args;
  sub->add_option("ARGS", args, "arguments");
  sub->allow_extras();
  return [] {
    std::cerr << "biodem: error: compare is not implemented yet in this version\n";
    return 2;
  };
}

}  // namespace biodem::cli
