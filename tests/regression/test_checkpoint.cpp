// Checkpoint/restart (SPEC 10): a run killed at an arbitrary moment and resumed with --resume
// produces exactly the same outputs as an uninterrupted run (bit for bit, same build and thread
// count); damaged or missing checkpoints give a clear error.
#include <gtest/gtest.h>

#include <algorithm>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include "test_util.hpp"

using namespace biodem::testing;
namespace fs = std::filesystem;

namespace {
const std::string kCase = source_dir() + "/tests/cases/checkpoint_tiny.toml";
}  // namespace

TEST(CheckpointRestart, KilledRunResumesBitForBit) {
  const std::string a = fresh_dir("ckpt_full"), b = fresh_dir("ckpt_killed");
  auto ra = run_command(biodem_exe() + " run " + kCase + " --out " + a + " --threads 1");
  ASSERT_EQ(ra.status, 0) << ra.output;

  // Start the same run, wait until it has written a checkpoint and moved on, then SIGKILL it.
  const std::string script = biodem_exe() + " run " + kCase + " --out " + b + " --threads 1 >/dev/null 2>&1 & pid=$!; " +
                             "for i in $(seq 1 600); do [ -f " + b + "/checkpoint.bin ] && break; sleep 0.05; done; " +
                             "sleep 0.2; kill -9 $pid 2>/dev/null; wait $pid 2>/dev/null; true";
  run_command("bash -c '" + script + "'");
  ASSERT_TRUE(fs::exists(b + "/checkpoint.bin"));
  const bool finished_anyway = slurp(b + "/run.log").find("finished:") != std::string::npos;
  auto rb = run_command(biodem_exe() + " run " + kCase + " --out " + b + " --threads 1 --resume");
  ASSERT_EQ(rb.status, 0) << rb.output;
  if (finished_anyway) GTEST_SKIP() << "the run finished before it could be killed; resume still succeeded";

  EXPECT_EQ(slurp(a + "/series.csv"), slurp(b + "/series.csv"));
  EXPECT_EQ(slurp(a + "/trace.csv"), slurp(b + "/trace.csv"));
  for (const char* pvd : {"/snapshots.pvd", "/bodies.pvd"}) EXPECT_EQ(slurp(a + pvd), slurp(b + pvd)) << pvd;
#if BIODEM_HAVE_OPENCV
  ASSERT_TRUE(fs::exists(a + "/speed_images"));  // a drum case: speed images at each snapshot
  ASSERT_FALSE(fs::is_empty(a + "/speed_images"));
  const auto dirs = {"/snapshots/", "/bodies/", "/speed_images/"};
#else
  const auto dirs = {"/snapshots/", "/bodies/"};  // (the lean build has no speed images)
#endif
  for (const char* dir : dirs)
    for (const auto& e : fs::directory_iterator(a + dir))
      EXPECT_EQ(slurp(e.path().string()), slurp(b + dir + e.path().filename().string()))
          << dir << e.path().filename();
}

TEST(CheckpointRestart, CorruptOrMissingCheckpointIsAClearError) {
  const std::string d = fresh_dir("ckpt_corrupt");
  auto r0 = run_command(biodem_exe() + " run " + kCase + " --out " + d + " --resume");
  EXPECT_NE(r0.status, 0);
  EXPECT_NE(r0.output.find("checkpoint.bin does not exist"), std::string::npos) << r0.output;

  auto r1 = run_command(biodem_exe() + " run " + kCase + " --out " + d + " --threads 1");
  ASSERT_EQ(r1.status, 0) << r1.output;
  {
    std::fstream f(d + "/checkpoint.bin", std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(200);
    f.put('\x5a');
  }
  auto r2 = run_command(biodem_exe() + " run " + kCase + " --out " + d + " --resume");
  EXPECT_NE(r2.status, 0);
  EXPECT_NE(r2.output.find("checksum"), std::string::npos) << r2.output;
  EXPECT_EQ(r2.output.find("internal error"), std::string::npos) << r2.output;
}

// An input refused after the case is read (here a resume with no checkpoint, or an output path
// that is a file) prints its one-line error alone, without the case's warnings before it (SPEC 11:
// "non-zero with a one-line message"); a run that starts still prints them. The case warns that
// its dt is 24.7 % of the Rayleigh time.
TEST(CheckpointRestart, RefusedRunPrintsItsErrorAloneAndAStartedRunItsWarnings) {
  const std::string d = fresh_dir("ckpt_error_alone");
  const auto one_line_error = [](const CommandResult& r, int status = 2) {  // (4: an output that cannot be written)
    EXPECT_EQ(r.status, status) << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
    EXPECT_EQ(r.output.rfind("biodem: error: ", 0), 0u) << r.output;
  };
  one_line_error(run_command(biodem_exe() + " run " + kCase + " --out " + d + " --resume"));
  fs::create_directories(d);
  { std::ofstream(d + "/a_file") << "x"; }
  ASSERT_TRUE(fs::is_regular_file(d + "/a_file"));
  one_line_error(run_command(biodem_exe() + " run " + kCase + " --out " + d + "/a_file --threads 1"), 4);
  const auto check = run_command(biodem_exe() + " check " + kCase);
  EXPECT_NE(check.output.find("warning: "), std::string::npos) << "the case no longer warns: " << check.output;
  const auto started = run_command(biodem_exe() + " run " + kCase + " --out " + d + "/run --threads 1");
  ASSERT_EQ(started.status, 0) << started.output;
  EXPECT_NE(started.output.find("warning: "), std::string::npos) << started.output;
}

// A fresh run into a folder that an earlier run and `biodem analyze` filled leaves none of the
// analysis (events.csv, descriptors.csv, threshold_sweep.csv, the plots): they described the
// series the run replaces (before, they stayed beside the new series.csv and looked current).
TEST(CheckpointRestart, FreshRunRemovesTheAnalysisOfTheRunItReplaces) {
  const std::string d = fresh_dir("fresh_over_analysed");
  ASSERT_EQ(run_command(biodem_exe() + " run " + kCase + " --out " + d + " --threads 1").status, 0);
  const auto a = run_command(biodem_exe() + " analyze " + d + " --sweep --min-drop-deg 0.01");
  ASSERT_EQ(a.status, 0) << a.output;
  auto analysis_files = [&] {
    std::vector<std::string> found;
    for (const auto& e : fs::directory_iterator(d)) {
      const std::string n = e.path().filename().string(), ext = e.path().extension().string();
      if (ext == ".png" || ext == ".svg" || n == "events.csv" || n == "descriptors.csv" || n == "threshold_sweep.csv")
        found.push_back(n);
    }
    return found;
  };
  ASSERT_GE(analysis_files().size(), 3u);  // the tables and the sweep (and the plots, with OpenCV)
  ASSERT_EQ(run_command(biodem_exe() + " run " + kCase + " --out " + d + " --threads 1").status, 0);
  EXPECT_EQ(analysis_files(), std::vector<std::string>{});
}

// `biodem check` reports the phase lengths in the steps the run makes: round(t / dt) for both
// (before, check rounded up: "0.025 revolutions = 0.05 s = 3334 steps" for a run of 3333).
TEST(CheckpointRestart, CheckReportsThePhaseStepsTheRunMakes) {
  const std::string d = fresh_dir("check_steps");
  fs::create_directories(d);
  std::string text = slurp(kCase);
  const std::string from = "revolutions = 0.06";
  ASSERT_NE(text.find(from), std::string::npos);
  text.replace(text.find(from), from.size(), "revolutions = 0.025");  // 0.05 s / 1.5e-5 s = 3333.3 steps
  std::ofstream(d + "/case.toml") << text;
  const auto c = run_command(biodem_exe() + " check " + d + "/case.toml");
  ASSERT_EQ(c.status, 0) << c.output;
  EXPECT_NE(c.output.find("rotate: 0.025 revolutions = 0.05 s = 3333 steps"), std::string::npos) << c.output;
  ASSERT_EQ(run_command(biodem_exe() + " run " + d + "/case.toml --out " + d + "/out --threads 1").status, 0);
  const std::string log = slurp(d + "/out/run.log");
  const std::size_t p = log.find("phase 'rotate' ends at t = ");
  ASSERT_NE(p, std::string::npos) << log;
  EXPECT_NE(log.substr(p, log.find('\n', p) - p).find(" after 3333 steps"), std::string::npos) << log.substr(p, 120);

  // series.csv gives each time and turn as whole steps x dt, end to end (this short run's sums of
  // dt happen to print the same at 12 digits; Steps.PhaseStepsAndTimesOfWholeSteps shows a sum
  // that does not).
  std::ifstream series(d + "/out/series.csv");
  std::string line;
  std::getline(series, line);
  int rows = 0, turning = 0;
  while (std::getline(series, line)) {
    const std::string t = line.substr(0, line.find(','));
    const std::string rev = line.substr(t.size() + 1, line.find(',', t.size() + 1) - t.size() - 1);
    const double dt = 1.5e-5;
    char want[64];
    std::snprintf(want, sizeof want, "%.12g", static_cast<double>(std::llround(std::stod(t) / dt)) * dt);
    EXPECT_EQ(t, want) << line;
    if (std::stod(rev) > 0.0) {  // revolution = rotating steps x dt x 30 rpm / 60
      ++turning;
      const double steps = std::stod(rev) * 60.0 / 30.0 / dt;
      EXPECT_NEAR(steps, std::round(steps), 1e-6) << line;
      std::snprintf(want, sizeof want, "%.12g", std::round(steps) * dt * 30.0 / 60.0);
      EXPECT_EQ(rev, want) << line;
    }
    ++rows;
  }
  EXPECT_GT(rows, 10);
  EXPECT_GT(turning, 3);
}

// The times of snapshots.pvd and bodies.pvd are whole steps times dt, as the series gives them:
// before, they were the summed clock, which after some 49,000 steps of 1.5e-5 s printed
// 0.731774999999 where the series said 0.731775. 50 beads, half a revolution (about 70,000 steps).
TEST(CheckpointRestart, SnapshotTimesAreWholeStepsTimesDt) {
  const std::string case_file = edited_case(kCase,
                                            {{"count = 400", "count = 50"},
                                             {"revolutions = 0.06", "revolutions = 0.5"},
                                             {"snapshot_every_s = 0.02", "snapshot_every_s = 0.0133"}},
                                            "pvd_times.toml");
  const std::string text = slurp(case_file);
  const std::string d = fresh_dir("pvd_times");
  const auto r = run_command(biodem_exe() + " run " + case_file + " --out " + d + " --threads 1");
  ASSERT_EQ(r.status, 0) << r.output;
  const double dt = 1.5e-5;
  ASSERT_NE(text.find("dt_s = 1.5e-5"), std::string::npos);
  for (const char* pvd : {"/snapshots.pvd", "/bodies.pvd"}) {
    const std::string x = slurp(d + pvd);
    std::size_t n = 0;
    for (auto at = x.find("timestep=\""); at != std::string::npos; at = x.find("timestep=\"", at + 1), ++n) {
      const double t = std::stod(x.substr(at + 10));
      EXPECT_LE(std::abs(t - std::round(t / dt) * dt), 1e-15) << pvd << " entry " << n << ": " << x.substr(at, 30);
    }
    EXPECT_GE(n, 70u) << pvd;
  }
}
