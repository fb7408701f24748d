// SIGINT / SIGTERM (SPEC 11): the run finishes the current step, writes a checkpoint, says so in
// one line and exits with 128 + signal (143 for SIGTERM); --resume then continues bit for bit.
// The signal is raised at chosen steps by a test hook (BIODEM_TEST_SIGNAL_AT_STEP), so the test
// cannot race the run; a real `kill -INT` is checked too.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>

#include "test_util.hpp"

using namespace biodem::testing;
namespace fs = std::filesystem;

namespace {
const std::string kCase = source_dir() + "/tests/cases/checkpoint_tiny.toml";
}  // namespace

TEST(Signals, TermWritesCheckpointAndResumeIsBitForBit) {
  for (const std::string device : {"cpu", "gpu-emulated"}) {
    const std::string a = fresh_dir("sig_full_" + device);
    ASSERT_EQ(run_command(biodem_exe() + " run " + kCase + " --out " + a + " --threads 1 --device " + device).status, 0);
    for (const char* step : {"1000", "6001"}) {  // settling, between checkpoints; rotating
      const std::string b = fresh_dir("sig_" + device + "_" + step);
      auto r = run_command("BIODEM_TEST_SIGNAL_AT_STEP=" + std::string(step) + " " + biodem_exe() + " run " + kCase +
                           " --out " + b + " --threads 1 --device " + device);
      EXPECT_EQ(r.status, 143) << r.output;
      EXPECT_NE(r.output.find("interrupted by SIGTERM"), std::string::npos) << r.output;
      EXPECT_NE(r.output.find("continue with --resume"), std::string::npos) << r.output;
      EXPECT_NE(slurp(b + "/run.log").find("interrupted by SIGTERM at t = "), std::string::npos);
      auto rr = run_command(biodem_exe() + " run " + kCase + " --out " + b + " --threads 1 --resume --device " + device);
      ASSERT_EQ(rr.status, 0) << rr.output;
      EXPECT_EQ(slurp(a + "/series.csv"), slurp(b + "/series.csv")) << device << " step " << step;
      EXPECT_EQ(slurp(a + "/trace.csv"), slurp(b + "/trace.csv")) << device << " step " << step;
      for (const char* pvd : {"/snapshots.pvd", "/bodies.pvd"}) EXPECT_EQ(slurp(a + pvd), slurp(b + pvd)) << pvd;
      // The final checkpoint too (on the GPU engine it differed in one byte, the host list's build
      // count, raised by the download of the signal's checkpoint).
      EXPECT_EQ(slurp(a + "/checkpoint.bin"), slurp(b + "/checkpoint.bin")) << device << " step " << step;
      for (const char* dir : {"/snapshots/", "/bodies/"})
        for (const auto& e : fs::directory_iterator(a + dir))
          EXPECT_EQ(slurp(e.path().string()), slurp(b + dir + e.path().filename().string()))
              << dir << e.path().filename();
    }
  }
}

TEST(Signals, RealSigintStopsWithACheckpoint) {
  const std::string d = fresh_dir("sig_real");
  const std::string script = biodem_exe() + " run " + kCase + " --out " + d + " --threads 1 >" + d +
                             ".out 2>&1 & pid=$!; for i in $(seq 1 600); do [ -f " + d +
                             "/checkpoint.bin ] && break; sleep 0.05; done; kill -INT $pid; wait $pid; echo status=$?";
  auto r = run_command("bash -c '" + script + "'");
  const bool finished = r.output.find("status=0") != std::string::npos;
  if (!finished) {
    EXPECT_NE(r.output.find("status=130"), std::string::npos) << r.output << slurp(d + ".out");
    EXPECT_NE(slurp(d + ".out").find("interrupted by SIGINT"), std::string::npos);
  }
  auto rr = run_command(biodem_exe() + " run " + kCase + " --out " + d + " --threads 1 --resume");
  EXPECT_EQ(rr.status, 0) << rr.output;
}

// A series.csv shorter than the checkpoint recorded (rows lost, e.g. a crash of the machine
// before they reached the disk) is an error on --resume, never NUL padding.
TEST(Signals, ResumeRefusesAnOutputShorterThanTheCheckpointRecorded) {
  const std::string d = fresh_dir("sig_short");
  auto r = run_command("BIODEM_TEST_SIGNAL_AT_STEP=3000 " + biodem_exe() + " run " + kCase + " --out " + d + " --threads 1");
  ASSERT_EQ(r.status, 143) << r.output;
  fs::resize_file(d + "/series.csv", fs::file_size(d + "/series.csv") / 2);
  auto rr = run_command(biodem_exe() + " run " + kCase + " --out " + d + " --threads 1 --resume");
  EXPECT_EQ(rr.status, 2) << rr.output;
  EXPECT_NE(rr.output.find("fewer than"), std::string::npos) << rr.output;
  EXPECT_EQ(slurp(d + "/series.csv").find('\0'), std::string::npos);
}

namespace {
/// checkpoint_tiny without periodic checkpoints, written next to `dir`.
std::string case_without_checkpoints(const std::string& dir) {
  std::string text = slurp(kCase), out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (line.rfind("checkpoint_every_s", 0) != 0) out += line + "\n";
  const std::string path = dir + "_case.toml";
  std::ofstream(path) << out;
  return path;
}
}  // namespace

// Without periodic checkpoints, a SIGTERM's checkpoint used to stay after the resumed run
// finished: a second --resume went back to it and cut the finished series.csv short. The final
// checkpoint is now written whenever one exists: the second --resume finds nothing left to do and
// every output stays that of an uninterrupted run.
TEST(Signals, SecondResumeOfAFinishedRunChangesNothing) {
  const std::string a = fresh_dir("sig_nock_full"), b = fresh_dir("sig_nock");
  const std::string c = case_without_checkpoints(b);
  ASSERT_EQ(run_command(biodem_exe() + " run " + c + " --out " + a + " --threads 1").status, 0);
  auto r = run_command("BIODEM_TEST_SIGNAL_AT_STEP=3000 " + biodem_exe() + " run " + c + " --out " + b + " --threads 1");
  ASSERT_EQ(r.status, 143) << r.output;
  for (int k = 0; k < 2; ++k) {
    auto rr = run_command(biodem_exe() + " run " + c + " --out " + b + " --threads 1 --resume");
    ASSERT_EQ(rr.status, 0) << "resume " << k << ": " << rr.output;
    EXPECT_EQ(slurp(a + "/series.csv"), slurp(b + "/series.csv")) << "after resume " << k;
    EXPECT_EQ(slurp(a + "/trace.csv"), slurp(b + "/trace.csv")) << "after resume " << k;
    // (the analysis of the finished series stays: the second resume neither cuts nor extends it)
    if (k == 0) {
      ASSERT_EQ(run_command(biodem_exe() + " analyze " + b).status, 0);
    }
  }
  EXPECT_TRUE(fs::exists(b + "/descriptors.csv"));
}

// Two runs writing into one folder corrupted each other's files (a resume started while the
// first run still ran left NUL bytes and duplicated rows, both exiting 0): the folder is locked
// for a run (flock on DIR/.biodem.lock), and a second run, fresh or resumed, is refused with one
// line before it touches anything.
TEST(Signals, RunIntoAFolderInUseIsRefused) {
  const std::string d = fresh_dir("sig_locked");
  auto r = run_command("BIODEM_TEST_SIGNAL_AT_STEP=3000 " + biodem_exe() + " run " + kCase + " --out " + d + " --threads 1");
  ASSERT_EQ(r.status, 143) << r.output;
  const std::string series = slurp(d + "/series.csv");
  // Hold the lock as a running biodem would (flock from a shell, while each command runs).
  for (const char* how : {" --resume", ""}) {
    auto rr = run_command("flock -n " + d + "/.biodem.lock " + biodem_exe() + " run " + kCase + " --out " + d +
                          " --threads 1" + how);
    EXPECT_EQ(rr.status, 4) << how << ": " << rr.output;
    EXPECT_NE(rr.output.find("another biodem run is writing to this folder"), std::string::npos) << rr.output;
    EXPECT_EQ(slurp(d + "/series.csv"), series) << how;
    EXPECT_TRUE(fs::exists(d + "/checkpoint.bin")) << how;
  }
  EXPECT_EQ(run_command(biodem_exe() + " run " + kCase + " --out " + d + " --threads 1 --resume").status, 0);
}

// A trace.csv that cannot be written (here a file size limit; a full disk alike) stops the run
// with one line: before, the run went on and said "done" with the trace cut off mid-row.
TEST(Signals, TraceThatCannotBeWrittenStopsTheRun) {
  const std::string d = fresh_dir("sig_fsize");
  // (SIGXFSZ at its default: biodem ignores it itself; before, the run died without a word)
  auto r = run_command("bash -c \"ulimit -f 300; " + biodem_exe() + " run " + kCase + " --out " + d + " --threads 1\"");
  EXPECT_EQ(r.status, 4) << r.output;
  EXPECT_NE(r.output.find("trace.csv: write failed"), std::string::npos) << r.output;
}

// run.log that cannot be written (a file size limit of 1 KB: its header is longer) stops the run
// with one line before any step, instead of a run whose log stays cut short. An output of the
// run that cannot be a file (a folder named run.log, series.csv or trace.csv) stops it too,
// instead of a series written inside the folder or an "internal error".
TEST(Signals, RunLogThatCannotBeWrittenStopsTheRun) {
  {
    const std::string d = fresh_dir("sig_runlog_limit");
    const auto r = run_command("bash -c \"ulimit -f 1; " + biodem_exe() + " run " + kCase + " --out " + d + " --threads 1\"");
    EXPECT_EQ(r.status, 4) << r.output;
    EXPECT_NE(r.output.find("run.log: cannot be written"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(d + "/series.csv")) << "stopped before any output";
  }
  const std::string d = fresh_dir("sig_runlog");
  fs::create_directories(d + "/run.log");
  auto r = run_command(biodem_exe() + " run " + kCase + " --out " + d + " --threads 1");
  EXPECT_EQ(r.status, 4) << r.output;
  EXPECT_NE(r.output.find("run.log is not a file (a folder?)"), std::string::npos) << r.output;
  // Likewise the other outputs (before: a folder named series.csv took the series inside it, one
  // named trace.csv gave an "internal error").
  for (const char* f : {"series.csv", "trace.csv/x"}) {
    const std::string o = fresh_dir(std::string("sig_outname_") + (f[0] == 's' ? "series" : "trace"));
    fs::create_directories(o + "/" + f);
    r = run_command(biodem_exe() + " run " + kCase + " --out " + o + " --threads 1");
    EXPECT_EQ(r.status, 4) << f << ": " << r.output;
    EXPECT_NE(r.output.find("is not a file (a folder?)"), std::string::npos) << f << ": " << r.output;
  }
  EXPECT_FALSE(fs::exists(d + "/series.csv")) << "stopped before any output";
}

// A resumed run removes the tables and plots of an earlier `biodem analyze` (they describe the
// series cut short at the checkpoint), as a fresh run does; a fresh run also removes the
// snapshot collections of the run before, which named its deleted files until the first
// snapshot.
TEST(Signals, ResumeAndFreshRunDropStaleAnalysisAndCollections) {
  const std::string d = fresh_dir("sig_stale");
  auto r = run_command("BIODEM_TEST_SIGNAL_AT_STEP=9000 " + biodem_exe() + " run " + kCase + " --out " + d + " --threads 1");
  ASSERT_EQ(r.status, 143) << r.output;
  ASSERT_EQ(run_command(biodem_exe() + " analyze " + d).status, 0);
  ASSERT_TRUE(fs::exists(d + "/descriptors.csv"));
  ASSERT_EQ(run_command(biodem_exe() + " run " + kCase + " --out " + d + " --threads 1 --resume").status, 0);
  EXPECT_FALSE(fs::exists(d + "/descriptors.csv"));
  EXPECT_FALSE(fs::exists(d + "/events.csv"));
  std::ofstream(d + "/snapshots.pvd") << "stale collection";
  std::ofstream(d + "/bodies.pvd") << "stale collection";
  r = run_command("BIODEM_TEST_ABORT_AT_STEP=5 " + biodem_exe() + " run " + kCase + " --out " + d + " --threads 1");
  for (const char* pvd : {"/snapshots.pvd", "/bodies.pvd"})
    EXPECT_EQ(slurp(d + pvd).find("stale collection"), std::string::npos) << pvd;
}

// --resume refuses with one line: a checkpoint of another case (named as such before its state
// is loaded: before, a state that did not fit this case gave "walls or shapes differ" or
// "corrupt checkpoint"), an appended output that is missing (before, an "internal error" from the
// file system), and a checkpoint.bin that is a folder (before, an "internal error" from reading it).
TEST(Signals, ResumeRefusesAnotherCaseAMissingOutputAndAFolder) {
  const std::string d = fresh_dir("sig_refuse");
  auto r = run_command("BIODEM_TEST_SIGNAL_AT_STEP=9000 " + biodem_exe() + " run " + kCase + " --out " + d + " --threads 1");
  ASSERT_EQ(r.status, 143) << r.output;
  ASSERT_EQ(run_command(biodem_exe() + " analyze " + d).status, 0);
  const std::string other = source_dir() + "/tests/cases/sink_tiny.toml";
  auto a = run_command(biodem_exe() + " run " + other + " --out " + d + " --threads 1 --resume");
  EXPECT_EQ(a.status, 2) << a.output;
  EXPECT_NE(a.output.find("was written for a different case file"), std::string::npos) << a.output;
  EXPECT_TRUE(fs::exists(d + "/descriptors.csv")) << "a refused resume changes nothing";
  fs::rename(d + "/trace.csv", d + "/trace.kept");
  const std::string series = slurp(d + "/series.csv");
  auto b = run_command(biodem_exe() + " run " + kCase + " --out " + d + " --threads 1 --resume");
  EXPECT_EQ(b.status, 2) << b.output;
  EXPECT_EQ(slurp(d + "/series.csv"), series) << "a refused resume cuts nothing";
  EXPECT_NE(b.output.find("trace.csv is missing"), std::string::npos) << b.output;
  EXPECT_EQ(b.output.find("internal error"), std::string::npos) << b.output;
  fs::rename(d + "/trace.kept", d + "/trace.csv");
  const std::string e = fresh_dir("sig_refuse_dir");
  fs::create_directories(e + "/checkpoint.bin");
  auto c = run_command(biodem_exe() + " run " + kCase + " --out " + e + " --threads 1 --resume");
  EXPECT_EQ(c.status, 2) << c.output;
  EXPECT_NE(c.output.find("not a regular file"), std::string::npos) << c.output;
  EXPECT_EQ(run_command(biodem_exe() + " run " + kCase + " --out " + d + " --threads 1 --resume").status, 0);
}

// An output folder that cannot be made, or an --out that names a file, is one line with status 4
// (an output that cannot be written) in every command: before, `run --resume` with its frames
// folder replaced by a file ended with "internal error: filesystem error" (status 3), `calibrate
// --out FILE` likewise, and `run --out FILE` gave 2 where compare and video gave 4.
TEST(Signals, OutputFoldersThatCannotBeMadeAreStatus4) {
  const std::string d = fresh_dir("sig_outdirs");
  fs::create_directories(d);
  std::ofstream(d + "/afile") << "x\n";
  for (const std::string& cmd :
       {" run " + kCase + " --out " + d + "/afile --threads 1", " run " + kCase + " --out " + d + "/afile/sub --threads 1",
        " calibrate " + source_dir() + "/tests/cases/calib_micro/campaign.toml --out " + d + "/afile",
        " calibrate " + source_dir() + "/tests/cases/calib_micro/campaign.toml --out " + d + "/afile/sub"}) {
    const auto r = run_command(biodem_exe() + cmd);
    EXPECT_EQ(r.status, 4) << cmd << ": " << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << cmd << ": " << r.output;
    EXPECT_EQ(r.output.rfind("biodem: error: ", 0), 0u) << cmd << ": " << r.output;
  }
  // A resumed run whose frames folder became a file.
  const std::string& c = kCase;
  const std::string o = d + "/run";
  auto r = run_command("BIODEM_TEST_SIGNAL_AT_STEP=300 " + biodem_exe() + " run " + c + " --out " + o + " --threads 1");
  ASSERT_EQ(r.status, 143) << r.output;
  for (const char* folder : {"snapshots", "frames", "speed_images"}) {
    fs::remove_all(o + "/" + folder);
    std::ofstream(o + "/" + folder) << "x\n";
    r = run_command(biodem_exe() + " run " + c + " --out " + o + " --threads 1 --resume");
    EXPECT_EQ(r.status, 4) << folder << ": " << r.output;
    EXPECT_NE(r.output.find(std::string(folder) + " is not a folder"), std::string::npos) << r.output;
    fs::remove(o + "/" + folder);
  }
}
