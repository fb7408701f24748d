// `biodem video`: placeholder until the analysis work lands.
#include <iostream>
#include <string>
#include <vector>

#include "commands.hpp"

namespace biodem::cli {

Action register_video(CLI::App& app) {
  auto* sub = app.add_subcommand("video", "video (not yet available)");
  static std::vector<std::string> args;
  sub->add_option("ARGS", args, "arguments");
  sub->allow_extras();
  return [] {
    std::cerr << "biodem: error: video is not implemented yet in this version\n";
    return 2;
  };
}

}  // namespace biodem::cli
