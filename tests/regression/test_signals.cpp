// SIGINT / SIGTERM (SPEC 11): the run finishes the current step, writes a checkpoint, says so in
// one line and exits with 128 + signal (143 for SIGTERM); --resume then continues bit for bit.
// The signal is raised at chosen steps by a test hook (BIODEM_TEST_SIGNAL_AT_STEP), so the test
// cannot race the run; a real `kill -INT` is checked too.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

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
