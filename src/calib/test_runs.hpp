// The bulk-test runs of a campaign: one job per (evaluation, [[test]]), each the test's case with
// the evaluation's parameters applied, run as `biodem run CASE --out DIR/out --threads 1` in its
// own folder DIR = OUT/runs/g<generation>/e<index>/<test>. A run that finished before a kill
// (same case text, run.log ends with "finished:") is re-used as it is: runs are deterministic.
#pragma once
#include <cstddef>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "calib/drum_test.hpp"

namespace biodem::calib {

struct TestJob {
  std::size_t evaluation = 0, test = 0;  // position in the batch, index of the [[test]]
  std::string dir;                       // the run's folder
  std::string case_text;                 // the test's case with the parameters applied
  std::vector<double> x;                 // the evaluation's decision vector
  std::optional<DrumAnalysis> drum;      // a drum test: its responses come from the analysis of its series
};

struct TestRun {
  int rc = 0;        // exit status of the run (0: it finished; 128 + N: stopped by signal N, or
                     // not started because the campaign was stopped by signal N)
  double wall_s = 0.0;
  bool started = true;  // false: not started, the campaign was stopping (rc 128 + signal)
  std::map<std::string, double> responses;  // responses.csv
  std::vector<std::string> warnings;         // run.log's warnings ("WARNING: ..."), for campaign.log
};

/// Why a test run's failure says nothing of its parameters, or "" when it may be scored: it could
/// not be started or its folder made (rc -1), a signal other than the campaign's stop ended it
/// (a kill, the memory limit), it ended with another status than biodem's 2 for a case or a
/// run that failed (an internal error), or with 4 because it could not write its outputs or its
/// folder was locked (the message is the last line of `dir`/stdout.txt). Such a failure stops the campaign
/// unscored, so that --resume runs it again, instead of caching 1e9 for good.
/// `crashed_before`: this run crashed (signal, internal error, not started) on an earlier attempt;
/// a second crash is scored as failed. Outputs that could not be written always stop.
std::string unscorable_failure(const TestRun& r, const std::string& dir, bool crashed_before = false);

/// Runs one job. The campaign's default runs `biodem` as a child process (run_test_process);
/// tests substitute a model of the bulk tests.
using TestRunner = std::function<TestRun(const TestJob&)>;

/// Writes `dir`/case.toml and runs `biodem_exe run` on it into `dir`/out (stdout and stderr to
/// `dir`/stdout.txt), or re-uses a finished earlier run of the same text, or resumes a stopped
/// one of the same text from its checkpoint (`run --resume`; from the start if that is refused);
/// reads its responses.csv. For a drum test (`drum`), a finished run's series is analysed
/// (measure_drum: events.csv, descriptors.csv and responses.csv beside it) instead.
TestRun run_test_process(const std::string& biodem_exe, const std::string& dir, const std::string& case_text,
                         const std::optional<DrumAnalysis>& drum = std::nullopt);

/// The signal that stopped a test run whose exit status is `rc` (SIGINT or SIGTERM: the run
/// finished its step, wrote its checkpoint and exited 130 or 143; or it was not started), or 0.
/// Such a run is neither finished nor failed: the campaign stops, and --resume resumes it.
int stopping_signal(int rc);

/// SIGINT and SIGTERM during a campaign (docs/calibration.md): while a CampaignSignals lives (the
/// campaign's process; not an MPI worker rank), the signal is recorded, passed on to the test
/// runs in progress (each finishes its step, writes its checkpoint and exits 128 + signal), and
/// no test run starts after it (run_test_process returns 128 + signal at once). Before, the
/// campaign ran its test runs through std::system, which ignores SIGINT in the caller: a Ctrl-C
/// stopped the runs, and the campaign scored them as failed and went on.
class CampaignSignals {
 public:
  CampaignSignals();
  ~CampaignSignals();
  CampaignSignals(const CampaignSignals&) = delete;
  CampaignSignals& operator=(const CampaignSignals&) = delete;
  /// The signal received since construction, or 0.
  static int received();
};

/// The program that runs the test cases: this process's executable (/proc/self/exe), or the light
/// `biodem` beside it when this is `biodem-full` (which runs `calibrate` for it).
std::string current_executable();

}  // namespace biodem::calib
