// The bulk-test runs of a campaign: one job per (evaluation, [[test]]), each the test's case with
// the evaluation's parameters applied, run as `biodem run CASE --out DIR/out --threads 1` in its
// own folder DIR = OUT/runs/g<generation>/e<index>/<test>. A run that finished before a kill
// (same case text, run.log ends with "finished:") is re-used as it is: runs are deterministic.
#pragma once
#include <cstddef>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace biodem::calib {

struct TestJob {
  std::size_t evaluation = 0, test = 0;  // position in the batch, index of the [[test]]
  std::string dir;                       // the run's folder
  std::string case_text;                 // the test's case with the parameters applied
  std::vector<double> x;                 // the evaluation's decision vector
};

struct TestRun {
  int rc = 0;        // exit status of the run (0: it finished)
  double wall_s = 0.0;
  std::map<std::string, double> responses;  // responses.csv
};

/// Runs one job. The campaign's default runs `biodem` as a child process (run_test_process);
/// tests substitute a model of the bulk tests.
using TestRunner = std::function<TestRun(const TestJob&)>;

/// Writes `dir`/case.toml and runs `biodem_exe run` on it into `dir`/out (stdout and stderr to
/// `dir`/stdout.txt), or re-uses a finished earlier run of the same text; reads its responses.csv.
TestRun run_test_process(const std::string& biodem_exe, const std::string& dir, const std::string& case_text);

/// The program that runs the test cases: this process's executable (/proc/self/exe), or the light
/// `biodem` beside it when this is `biodem-full` (which runs `calibrate` for it).
std::string current_executable();

}  // namespace biodem::calib
