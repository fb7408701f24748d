#include "calib/test_runs.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "core/error.hpp"
#include "output/output_dir.hpp"

extern char** environ;

namespace biodem::calib {
namespace {

namespace fs = std::filesystem;

// A test run of an earlier (killed) attempt at the same evaluation: same case text, and its
// run.log ends with "finished:" (written after responses.csv; a drum test's responses are
// measured again from its series).
bool finished_run(const std::string& dir, const std::string& text, bool drum) {
  std::ifstream c(dir + "/case.toml"), l(dir + "/out/run.log");
  if (!c || !l) return false;
  const std::string old((std::istreambuf_iterator<char>(c)), std::istreambuf_iterator<char>());
  const std::string log((std::istreambuf_iterator<char>(l)), std::istreambuf_iterator<char>());
  return old == text && log.find("\nfinished: ") != std::string::npos &&
         (drum || fs::exists(dir + "/out/responses.csv"));
}

// The last line of a resumed run's output says its checkpoint was refused (corrupt, or of
// another case): the run goes again from the start. Any other error is the run's own.
bool checkpoint_refused(const std::string& log) {
  std::ifstream in(log);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  return last.find("checkpoint.bin") != std::string::npos || last.find("--resume") != std::string::npos;
}

// A test run of the same case text that a signal stopped: it left a checkpoint and no "finished:".
bool stopped_run(const std::string& dir, const std::string& text) {
  std::ifstream c(dir + "/case.toml");
  if (!c || !fs::exists(dir + "/out/checkpoint.bin")) return false;
  const std::string old((std::istreambuf_iterator<char>(c)), std::istreambuf_iterator<char>());
  return old == text;
}

// The campaign's stop signal and the test runs in progress, read by the signal handler (lock-free
// atomics only). A run started after more runs than slots at once is not registered: it still
// gets a terminal's SIGINT, and no run starts after the signal.
std::atomic<int> g_signal{0};
std::array<std::atomic<pid_t>, 1024> g_children{};

extern "C" void on_campaign_signal(int sig) {
  const int saved_errno = errno;  // kill() may set it in the thread the signal interrupted
  g_signal.store(sig);
  for (auto& c : g_children)
    if (const pid_t p = c.load(); p > 0) ::kill(p, sig);
  errno = saved_errno;
}

struct sigaction g_old_int, g_old_term;

// Runs `args` (args[0] the program) with stdout and stderr to `log`, as a registered child: a
// campaign signal that arrives before the child is registered is passed on right after. Returns
// its exit status, 128 + N when signal N ended it, -1 when it could not be started.
int run_child(const std::vector<std::string>& args, const std::string& log, bool append) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | (append ? O_APPEND : O_TRUNC), 0644);
  posix_spawn_file_actions_adddup2(&fa, 1, 2);
  pid_t pid = 0;
  const int err = ::posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (err != 0) return -1;
  std::atomic<pid_t>* slot = nullptr;
  for (auto& c : g_children) {
    pid_t empty = 0;
    if (c.compare_exchange_strong(empty, pid)) {
      slot = &c;
      break;
    }
  }
  if (const int sig = g_signal.load()) ::kill(pid, sig);
  // Wait for the exit without reaping it, unregister, then reap: the handler never signals a
  // pid that has been freed (and could belong to another process by then).
  siginfo_t info{};
  int w;
  while ((w = ::waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOWAIT)) < 0 && errno == EINTR) {
  }
  if (slot) slot->store(0);
  int st = 0;
  pid_t reaped;
  while ((reaped = ::waitpid(pid, &st, 0)) < 0 && errno == EINTR) {
  }
  if (w < 0 || reaped != pid) return -1;  // (no status to read: not a success)
  if (WIFEXITED(st)) return WEXITSTATUS(st);
  if (WIFSIGNALED(st)) return 128 + WTERMSIG(st);
  return -1;
}

}  // namespace

int stopping_signal(int rc) {
  return rc == 128 + SIGINT ? SIGINT : rc == 128 + SIGTERM ? SIGTERM : 0;
}

CampaignSignals::CampaignSignals() {
  g_signal.store(0);
  struct sigaction sa {};
  sa.sa_handler = on_campaign_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  ::sigaction(SIGINT, &sa, &g_old_int);
  ::sigaction(SIGTERM, &sa, &g_old_term);
}

CampaignSignals::~CampaignSignals() {
  ::sigaction(SIGINT, &g_old_int, nullptr);
  ::sigaction(SIGTERM, &g_old_term, nullptr);
}

int CampaignSignals::received() { return g_signal.load(); }

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

namespace {

TestRun run_test_process_or_throw(const std::string& biodem_exe, const std::string& dir, const std::string& case_text,
                                  const std::optional<DrumAnalysis>& drum) {
  TestRun r;
  if (const int sig = g_signal.load()) {  // the campaign is stopping: start nothing
    r.rc = 128 + sig;
    r.started = false;
    return r;
  }
  if (std::error_code ec; fs::create_directories(dir, ec), ec)
    throw OutputError(dir + ": cannot create the test run's folder (" + ec.message() + ")");
  const auto t0 = std::chrono::steady_clock::now();
  if (!finished_run(dir, case_text, drum.has_value())) {  // a run finished before a kill is re-used as it is (deterministic)
    std::vector<std::string> args = {biodem_exe, "run", dir + "/case.toml", "--out", dir + "/out", "--threads", "1"};
    // A run of the same text stopped by a signal resumes from its checkpoint (bit for bit);
    // should the checkpoint be refused (status 2), it runs again from the start.
    bool resumed = false;
    if (stopped_run(dir, case_text)) {
      args.push_back("--resume");
      r.rc = run_child(args, dir + "/stdout.txt", true);
      args.pop_back();
      resumed = !(r.rc == 2 && checkpoint_refused(dir + "/stdout.txt"));
    }
    if (!resumed) {
      // The outputs of an earlier run of another text go first: a run stopped before it cleared
      // them must not leave their "finished:" and responses beside the new case text.
      fs::remove(dir + "/out/run.log");
      fs::remove(dir + "/out/responses.csv");
      output::write_file_atomic(dir + "/case.toml", case_text);  // (a cut-off text could still parse)
      r.rc = run_child(args, dir + "/stdout.txt", false);
    }
  }
  std::string line;
  if (drum) {
    // The drum's descriptors from its series, once the run has finished (rc 0 or re-used).
    if (r.rc == 0) {
      try {  // (on a worker thread or an MPI rank: nothing may escape)
        DrumMeasurement m = measure_drum(dir + "/out", *drum);
        r.responses = std::move(m.responses);
        r.warnings = std::move(m.warnings);
      } catch (const std::exception& e) {
        r.warnings.push_back(std::string("WARNING: drum test: the series cannot be analysed: ") + e.what());
      }
    }
  } else {
    std::ifstream in(dir + "/out/responses.csv");
    std::getline(in, line);
    while (std::getline(in, line)) {
      const auto c1 = line.find(','), c2 = line.find(',', c1 + 1);
      if (c1 == std::string::npos || c2 == std::string::npos) continue;
      r.responses[line.substr(0, c1)] = std::stod(line.substr(c1 + 1, c2 - c1 - 1));
    }
  }
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // The run's warnings (a fill too low or too high for the heap procedure, a scene not at rest
  // when measured): the campaign reports them, as its responses may not mean what they say.
  std::ifstream log(dir + "/out/run.log");
  while (std::getline(log, line))
    if (const auto w = line.find("WARNING: ");
        w != std::string::npos && line.find("the host gave this run only") == std::string::npos)  // (a timing note)
      r.warnings.push_back(line.substr(w));
  return r;
}


}  // namespace

TestRun run_test_process(const std::string& biodem_exe, const std::string& dir, const std::string& case_text,
                         const std::optional<DrumAnalysis>& drum) {
  // (on a worker thread or an MPI rank: nothing may escape; a folder that cannot be made, a
  // responses.csv that cannot be read, is a failure that stops the campaign unscored)
  try {
    return run_test_process_or_throw(biodem_exe, dir, case_text, drum);
  } catch (const OutputError& e) {  // (its folder or case.toml could not be written: as a run's status 4)
    TestRun r;
    r.rc = 4;
    r.started = false;
    r.warnings.push_back(std::string("the test run could not be made: ") + e.what());
    return r;
  } catch (const std::exception& e) {
    TestRun r;
    r.rc = -1;
    r.warnings.push_back(std::string("the test run could not be made: ") + e.what());
    return r;
  }
}

std::string unscorable_failure(const TestRun& r, const std::string& dir, bool crashed_before) {
  if (r.rc == 0 || stopping_signal(r.rc)) return "";
  // A crash (a signal, an internal error, a run not started) is retried once by --resume; the
  // same run crashing again is taken for what its parameters do (scored as failed), or the
  // campaign could never finish.
  if (r.rc == -1 && !crashed_before)
    return "could not be started, or its end not read" + (r.warnings.empty() ? std::string() : " (" + r.warnings.back() + ")");
  if (r.rc > 128 && !crashed_before)
    return "was ended by signal " + std::to_string(r.rc - 128) + " (killed from outside, or for memory)";
  if (r.rc == 4) {
    // Exit status 4: the run could not write its outputs (a full disk, permissions, a file size
    // limit, its folder held by another biodem process). The reason is biodem's one-line error
    // of this attempt, the last line of stdout.txt (a resumed run appends to it), or, for a run
    // whose folder or case could not be written, why.
    if (!r.started && !r.warnings.empty()) return "could not write its outputs: " + r.warnings.back();
    std::ifstream in(dir + "/stdout.txt");
    std::string line, last;
    while (std::getline(in, line))
      if (line.find_first_not_of(" \t\r") != std::string::npos) last = line;
    return "could not write its outputs" + (last.empty() ? std::string() : ": " + last);
  }
  if (r.rc != 2 && r.rc != -1 && r.rc <= 128 && !crashed_before)
    return "ended with status " + std::to_string(r.rc) + " (an internal error; see " + dir + "/stdout.txt)";
  return "";
}
}  // namespace biodem::calib
