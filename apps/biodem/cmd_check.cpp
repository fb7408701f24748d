// `biodem check CASE`: parse and validate a case without running it; warnings go to stderr
// (prefixed "warning: "), the resolved case and its derived quantities to stdout.
#include <iostream>
#include <string>

#include "commands.hpp"
#include "case_file/case_parser.hpp"
#include "output/case_report.hpp"

namespace biodem::cli {

Action register_check(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "check", "Validate a case and print derived quantities (n_spb, clump length, volume, d_eq, mass, inertia, "
               "Rayleigh time, dt as % of it, particle count for a fill fraction) without running");
  static std::string case_path;
  sub->add_option("CASE", case_path, "case file (TOML)")->required();
  return [] {
    const case_file::LoadedCase loaded = case_file::load_case(case_path);  // biodem::Error -> main prints it, exit 2
    for (const auto& w : loaded.warnings) std::cerr << "warning: " << w << "\n";
    std::cout << output::describe_case(loaded.config) << std::flush;
    return 0;
  };
}

}  // namespace biodem::cli
