// `biodem run CASE --out DIR [--threads N] [--resume]` (SPEC 11).
#include <iostream>
#include <string>

#include "commands.hpp"
#include "driver/run_driver.hpp"
#include "io/case_parser.hpp"
#include "io/progress.hpp"

namespace biodem::cli {

Action register_run(CLI::App& app) {
  auto* sub = app.add_subcommand("run", "Run a case: insertion, phases, series.csv, snapshots, run.log");
  static std::string case_path, out_dir;
  static int threads = 0;
  static bool resume = false;
  sub->add_option("CASE", case_path, "case file (TOML)")->required();
  sub->add_option("--out", out_dir, "output directory (created if needed)")->required();
  sub->add_option("--threads", threads, "OpenMP threads (default: all cores)")->check(CLI::NonNegativeNumber);
  sub->add_flag("--resume", resume, "continue from the last checkpoint in --out");
  return [] {
    const io::LoadedCase loaded = io::load_case(case_path);
    for (const auto& w : loaded.warnings) std::cerr << "warning: " << w << "\n";
    driver::RunOptions opt;
    opt.out_dir = out_dir;
    opt.threads = threads;
    opt.resume = resume;
    opt.progress_tty = io::Progress::stderr_is_terminal();
    driver::run_case(loaded, opt);
    return 0;
  };
}

}  // namespace biodem::cli
