// `biodem run CASE --out DIR [--threads N] [--resume]` (placeholder until the engine lands).
#include <iostream>
#include <string>

#include "commands.hpp"

namespace biodem::cli {

Action register_run(CLI::App& app) {
  auto* sub = app.add_subcommand("run", "Run a case");
  static std::string case_path, out_dir;
  static int threads = 0;
  static bool resume = false;
  sub->add_option("CASE", case_path, "case file (TOML)")->required();
  sub->add_option("--out", out_dir, "output directory")->required();
  sub->add_option("--threads", threads, "OpenMP threads (default: all cores)");
  sub->add_flag("--resume", resume, "continue from the last checkpoint in --out");
  return [] {
    std::cerr << "biodem: error: run is not implemented yet\n";
    return 2;
  };
}

}  // namespace biodem::cli
