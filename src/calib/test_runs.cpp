#include "calib/test_runs.hpp"

#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>

namespace biodem::calib {
namespace {

namespace fs = std::filesystem;

// A test run of an earlier (killed) attempt at the same evaluation: same case text, and its
// run.log ends with "finished:" (written after responses.csv).
bool finished_run(const std::string& dir, const std::string& text) {
  std::ifstream c(dir + "/case.toml"), l(dir + "/out/run.log");
  if (!c || !l) return false;
  const std::string old((std::istreambuf_iterator<char>(c)), std::istreambuf_iterator<char>());
  const std::string log((std::istreambuf_iterator<char>(l)), std::istreambuf_iterator<char>());
  return old == text && log.find("\nfinished: ") != std::string::npos && fs::exists(dir + "/out/responses.csv");
}

}  // namespace

std::string current_executable() {
  const fs::path self = fs::read_symlink("/proc/self/exe");
  // biodem-full, which runs `calibrate` for the light biodem (apps/biodem/forward.cpp), starts
  // the test runs with the light biodem beside it: the same `run`, without loading the
  // libraries of video and calibrate at each start.
  if (self.filename() == "biodem-full") {
    const fs::path light = self.parent_path() / "biodem";
    if (::access(light.c_str(), X_OK) == 0) return light.string();
  }
  return self.string();
}

TestRun run_test_process(const std::string& biodem_exe, const std::string& dir, const std::string& case_text) {
  TestRun r;
  fs::create_directories(dir);
  const auto t0 = std::chrono::steady_clock::now();
  if (!finished_run(dir, case_text)) {  // a run finished before a kill is re-used as it is (deterministic)
    { std::ofstream(dir + "/case.toml") << case_text; }
    const std::string cmd = "'" + biodem_exe + "' run '" + dir + "/case.toml' --out '" + dir +
                            "/out' --threads 1 > '" + dir + "/stdout.txt' 2>&1";
    r.rc = std::system(cmd.c_str());
  }
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::ifstream in(dir + "/out/responses.csv");
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    const auto c1 = line.find(','), c2 = line.find(',', c1 + 1);
    if (c1 == std::string::npos || c2 == std::string::npos) continue;
    r.responses[line.substr(0, c1)] = std::stod(line.substr(c1 + 1, c2 - c1 - 1));
  }
  return r;
}

}  // namespace biodem::calib
