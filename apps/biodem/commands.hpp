// Each sub-command registers itself on the CLI11 app and returns the callback to run when chosen.
#pragma once
#include <CLI/CLI.hpp>
#include <exception>
#include <functional>
#include <string>

namespace biodem::cli {

using Action = std::function<int()>;

/// A whole number of at least `lo` (for --threads, --jobs): the message says which of the two
/// the value is not (CLI11's ranges print the largest double and call a word out of range).
inline CLI::Validator whole_number_at_least(long lo) {
  return CLI::Validator(
      [lo](std::string& s) -> std::string {
        std::size_t used = 0;
        long v = 0;
        try {
          v = std::stol(s, &used);
        } catch (const std::exception&) {
          used = 0;
        }
        if (used == 0 || used != s.size()) return "must be a whole number, got '" + s + "'";
        if (v < lo) return "must be at least " + std::to_string(lo) + ", got " + s;
        return {};
      },
      "INT>=" + std::to_string(lo));
}

Action register_run(CLI::App& app);
Action register_check(CLI::App& app);
Action register_analyze(CLI::App& app);
Action register_compare(CLI::App& app);
Action register_video(CLI::App& app);
Action register_calibrate(CLI::App& app);

/// The one-line summaries of `biodem --help`.
inline constexpr const char* kVideoSummary =
    "Centroid angle alpha and surface r^2 series from a folder of back-lit drum frames "
    "(PNG/JPEG/TIFF, sorted by name) or a video file (.avi, .mp4, ...) into DIR/series.csv, "
    "ready for analyze";
inline constexpr const char* kCalibrateSummary = "Bulk-test calibration campaign (NSGA-II over case parameters)";

#if BIODEM_FORWARDS
/// True for the commands the light `biodem` hands to `biodem-full` (forward.cpp).
bool forwarded(const char* command);
/// Runs `biodem-full` from the same folder with the same arguments (exec); returns only on
/// failure, with the exit status after an error message.
int forward(char** argv);
#endif

}  // namespace biodem::cli
