// biodem command line: one program, sub-commands (SPEC 11). Built twice: `biodem-full` with
// every command, and `biodem` (BIODEM_FORWARDS) without the libraries of video and calibrate,
// which it hands to biodem-full (forward.cpp).
#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <string>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "core/error.hpp"
#include "output/build_info.hpp"

int main(int argc, char** argv) {
  // A write past a file size limit (ulimit -f) fails with EFBIG, which the writers report in one
  // line naming the file, instead of the default SIGXFSZ ending the process without a word or a
  // checkpoint. (Kept across the exec of biodem-full and by a campaign's test runs.)
  std::signal(SIGXFSZ, SIG_IGN);
#if BIODEM_FORWARDS
  if (argc > 1 && biodem::cli::forwarded(argv[1])) return biodem::cli::forward(argv);
#endif
  CLI::App app{"biodem: DEM of cohesive, elongated biomass powders in a rotating drum"};
  app.require_subcommand(1);
  app.set_version_flag("--version", biodem::output::build_description());

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

  // A first word that is no command and no option: name it (CLI11 would say only that a
  // sub-command is required).
  if (argc > 1 && argv[1][0] != '-') {
    bool known = false;
    std::string names;
    for (const auto& [sub, action] : actions) {
      known = known || sub->get_name() == argv[1];
      names += (names.empty() ? "" : ", ") + sub->get_name();
    }
    if (!known) {
      std::cerr << "biodem: error: unknown command '" << argv[1] << "' (expected one of " << names
                << "; see biodem --help)\n";
      return 2;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    // One line naming the option (SPEC 11), status 2 as every user-facing error.
    std::string what = e.what();
    for (char& c : what)
      if (c == '\n') c = ' ';
    while (!what.empty() && what.back() == ' ') what.pop_back();
    std::cerr << "biodem: error: " << what << " (see biodem --help)\n";
    return 2;
  }
  try {
    for (auto& [sub, action] : actions)
      if (sub->parsed()) return action();
  } catch (const biodem::Error& e) {
    // 2: the input; 4: an output that cannot be written; 3: a device fault or an internal error.
    std::cerr << "biodem: error: " << e.what() << "\n";
    if (dynamic_cast<const biodem::OutputError*>(&e)) return 4;
    if (dynamic_cast<const biodem::InternalError*>(&e)) return 3;
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "biodem: internal error: " << e.what() << "\n";
    return 3;
  }
  return 1;
}
