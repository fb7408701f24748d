// The light `biodem` (run, check, analyze, compare) hands `video` and `calibrate` to
// `biodem-full`, built beside it: those two commands need OpenCV's video and image codecs, pagmo
// and MPI, about 230 shared libraries that would otherwise be loaded at every start (0.3 s, 3 %
// of a 10 s run, and more in a calibration campaign that starts the program for each test run).
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <string_view>

#include "commands.hpp"

namespace biodem::cli {

namespace {
constexpr const char* kFull = "biodem-full";

/// Lists the command in `biodem --help`; the command itself never gets here (main forwards it
/// before parsing).
Action listed_only(CLI::App& app, const char* name, const char* summary) {
  auto* sub = app.add_subcommand(name, summary);
  sub->allow_extras();
  return []() -> int { return 1; };
}
}  // namespace

Action register_video(CLI::App& app) { return listed_only(app, "video", kVideoSummary); }
Action register_calibrate(CLI::App& app) { return listed_only(app, "calibrate", kCalibrateSummary); }

bool forwarded(const char* command) {
  const std::string_view c = command;
  return c == "video" || c == "calibrate";
}

int forward(char** argv) {
  std::error_code ec;
  std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) self = argv[0];
  const std::filesystem::path full = self.parent_path() / kFull;
  ::execv(full.c_str(), argv);  // returns only on failure; argv[0] stays, so messages say biodem
  std::cerr << "biodem: error: " << argv[1] << ": cannot start " << full.string() << " (" << std::strerror(errno)
            << "); it is built and installed beside biodem, which runs video and calibrate through it\n";
  return 2;
}

}  // namespace biodem::cli
