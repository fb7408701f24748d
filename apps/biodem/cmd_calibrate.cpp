// `biodem calibrate`: NSGA-II bulk-test calibration (SPEC 7) is later work; until it exists the
// command says so and fails, never pretends.
#include <iostream>
#include <string>

#include "commands.hpp"

namespace biodem::cli {

Action register_calibrate(CLI::App& app) {
  auto* sub = app.add_subcommand("calibrate", "Bulk-test calibration campaign (NSGA-II) - not yet available");
  static std::string calib_path, out_dir;
  sub->add_option("CALIB", calib_path, "calibration case (TOML)");
  sub->add_option("--out", out_dir, "output directory");
  return [] {
    std::cerr << "biodem: error: calibrate is not implemented yet in this version\n";
    return 2;
  };
}

}  // namespace biodem::cli
