// Each sub-command registers itself on the CLI11 app and returns the callback to run when chosen.
#pragma once
#include <CLI/CLI.hpp>
#include <functional>

namespace biodem::cli {

using Action = std::function<int()>;

Action register_run(CLI::App& app);
Action register_check(CLI::App& app);
Action register_analyze(CLI::App& app);
Action register_compare(CLI::App& app);
Action register_video(CLI::App& app);
Action register_calibrate(CLI::App& app);

}  // namespace biodem::cli
