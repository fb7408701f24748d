// biodem command line: one program, sub-commands (SPEC 11).
#include <CLI/CLI.hpp>
#include <cstdlib>
#include <exception>
#include <unistd.h>
#include <iostream>
#include <string_view>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "core/error.hpp"

// How long an idle OpenMP thread spins before it sleeps. GNU OpenMP reads GOMP_SPINCOUNT once,
// when the library loads (before main). Its default, 300,000 spins (several ms), kept libgomp's
// idle threads spinning after each neighbour-list build (an OpenMP loop) while the step's own
// thread team (core/spin_team.hpp) needed the cores; on the 2-vCPU development VM that, and
// OpenMP's waiting in general, made 2-thread runs vary from 0.55x to 1.8x the 1-thread speed from
// launch to launch (docs/performance.md). 3,000 spins is tens of microseconds. So, unless the
// user set GOMP_SPINCOUNT or OMP_WAIT_POLICY, biodem sets it and executes itself again, once,
// at start. Only `run` with more than one thread has OpenMP worker threads that could spin, so
// only it pays for the second start (loading the ~250 shared libraries of OpenCV, MPI and CUDA
// again: about 0.45 s on the 2-vCPU VM); `check`, `analyze`, `video`, `compare`, `calibrate`
// (whose test runs are `biodem run` processes) and `run --threads 1` start once. (Setting the
// variable from .preinit_array instead does not work: glibc's own initialisation, which runs
// after it, resets the environment to the one the process started with.)
namespace {
bool runs_openmp_threads(int argc, char** argv) {
  if (argc < 2 || std::string_view(argv[1]) != "run") return false;
  for (int k = 2; k < argc; ++k) {
    const std::string_view a(argv[k]);
    if (a == "--threads" && k + 1 < argc) return std::string_view(argv[k + 1]) != "1";
    if (a == "--threads=1") return false;
  }
  return true;  // --threads N > 1, or all cores
}

void set_openmp_spin_and_reexec(int argc, char** argv) {
#if defined(__linux__)
  if (!runs_openmp_threads(argc, argv)) return;
  if (std::getenv("GOMP_SPINCOUNT") != nullptr || std::getenv("OMP_WAIT_POLICY") != nullptr) return;
  if (setenv("GOMP_SPINCOUNT", "3000", 1) != 0) return;
  execv("/proc/self/exe", argv);  // returns only on failure: carry on with the library default
  unsetenv("GOMP_SPINCOUNT");
#else
  (void)argc;
  (void)argv;
#endif
}
}  // namespace

int main(int argc, char** argv) {
  set_openmp_spin_and_reexec(argc, argv);
  CLI::App app{"biodem: DEM of cohesive, elongated biomass powders in a rotating drum"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "biodem 0.1.0");

  std::vector<std::pair<CLI::App*, biodem::cli::Action>> actions;
  auto add = [&](auto reg) {
    const std::size_t before = app.get_subcommands({}).size();
    biodem::cli::Action a = reg(app);
    actions.emplace_back(app.get_subcommands({}).at(before), std::move(a));
  };
  add(biodem::cli::register_run);
  add(biodem::cli::register_check);
  add(biodem::cli::register_analyze);
  add(biodem::cli::register_compare);
  add(biodem::cli::register_video);
  add(biodem::cli::register_calibrate);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    for (auto& [sub, action] : actions)
      if (sub->parsed()) return action();
  } catch (const biodem::Error& e) {
    std::cerr << "biodem: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "biodem: internal error: " << e.what() << "\n";
    return 3;
  }
  return 1;
}
