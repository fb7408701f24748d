// `biodem run CASE --out DIR [--threads N] [--resume] [--device cpu|gpu]` (SPEC 11).
#include <iostream>
#include <string>

#include "commands.hpp"
#include "driver/run_driver.hpp"
#include "case_file/case_parser.hpp"
#include "output/progress.hpp"

namespace biodem::cli {

Action register_run(CLI::App& app) {
  auto* sub = app.add_subcommand("run", "Run a case: insertion, phases, series.csv, snapshots, run.log");
  static std::string case_path, out_dir;
  static int threads = 0;
  static bool resume = false, profile = false;
  static std::string device;
  sub->add_option("CASE", case_path, "case file (TOML)")->required();
  sub->add_option("--out", out_dir, "output directory (created if needed)")->required();
  sub->add_option("--threads", threads, "threads of the engine (default: all cores)")->check(whole_number_at_least(0));
  sub->add_flag("--resume", resume, "continue from the last checkpoint in --out");
  sub->add_flag("--profile", profile, "time the phases of the CPU engine's step and write them to run.log");
  sub->add_option("--device", device,
                  "engine: cpu (default), gpu (CUDA GPU engine), or gpu-emulated (the GPU engine's kernels on CPU "
                  "threads, for testing); overrides [run] device")
      ->check(CLI::IsMember({"cpu", "gpu", "gpu-emulated"}));
  return [] {
    const case_file::LoadedCase loaded = case_file::load_case(case_path);
    driver::RunOptions opt;
    // The case's warnings once the run is sure to start: an input refused later (device, output
    // folder, checkpoint) then prints its one-line error alone (SPEC 11).
    opt.on_start = [&loaded] {
      for (const auto& w : loaded.warnings) std::cerr << "warning: " << w << "\n";
    };
    opt.out_dir = out_dir;
    opt.threads = threads;
    opt.resume = resume;
    opt.profile = profile;
    if (device == "cpu") opt.device = config::Device::Cpu;
    if (device == "gpu") opt.device = config::Device::Gpu;
    if (device == "gpu-emulated") opt.device = config::Device::GpuEmulated;
    opt.progress_tty = output::Progress::stderr_is_terminal();
    try {
      driver::run_case(loaded, opt);
    } catch (const driver::Interrupted& e) {
      std::cerr << "biodem: " << e.what() << "\n";
      return 128 + e.signal;  // 130 for SIGINT, 143 for SIGTERM (docs/outputs.md)
    }
    return 0;
  };
}

}  // namespace biodem::cli
