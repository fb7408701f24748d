// The GPU engine's list guard through `biodem run` (docs/gpu.md, "The list guard"): an explicit
// scene whose bodies outrun the list check's prediction. Two beads placed overlapping by 0.3 mm
// ([run] allow_initial_overlap) push apart at 29,000 m/s^2 and strike a third that waits 0.12 um
// beyond the 0.1 um skin. The CPU engine rebuilds its list whenever a sphere has passed half the
// skin; the GPU engine (its kernels on CPU threads here) stops the device after such a drift and
// builds the list there. Before 2026-11-28 it stopped the run ("more than half the skin"), which
// BIODEM_GPU_LIST_GUARD=0 still does.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "test_util.hpp"

using namespace biodem::testing;
namespace fs = std::filesystem;

namespace {

const std::string kScene = R"([run]
dt_s = 2.0e-7
gravity_m_s2 = [0.0, 0.0, 0.0]
skin_m = 1.0e-7
allow_initial_overlap = true
bounds_min_m = [-0.01, -0.01, -0.01]
bounds_max_m = [0.01, 0.01, 0.01]

)" + bead_material_pair_shape("2.0e-3") + bead_particle("[-0.00085, 0.0, 0.0]") +
                          bead_particle("[0.00085, 0.0, 0.0]") + bead_particle("[0.00285012, 0.0, 0.0]") + R"(
[[phase]]
name = "push"
duration_s = 0.0004

[output]
sample_hz = 100000.0
trace = true
checkpoint_every_s = 0.0001
)";

std::string write_case(const std::string& name) {
  const std::string dir = fresh_dir(name);
  fs::create_directories(dir);
  std::ofstream(dir + "/case.toml") << kScene;
  return dir;
}

}  // namespace

// The run completes on both engines with the same trajectories (the trace's last rows to 1e-9),
// the GPU engine's run.log counts the guard's stops, a run stopped by SIGTERM between two of them
// and resumed ends with the bytes of the uninterrupted one, and without the guard the run stops
// with the half-skin line.
TEST(ListGuardRun, BeadsOutrunningTheListCheckRunToTheEndOnTheGpuEngineAsOnTheCpuEngine) {
  std::vector<std::vector<double>> last;
  std::string full;  // (the GPU engine's run, uninterrupted)
  for (const std::string device : {"cpu", "gpu-emulated"}) {
    SCOPED_TRACE(device);
    const std::string d = write_case("guard_run_" + device);
    full = d + "/out";
    auto r = run_command(biodem_exe() + " run " + d + "/case.toml --out " + d + "/out --threads 1 --device " + device);
    ASSERT_EQ(r.status, 0) << r.output;
    const auto t = read_csv(d + "/out/trace.csv");
    const auto vx = to_numbers(t.at("vx_m_s"));
    ASSERT_GE(vx.size(), 3u);
    last.push_back({vx[vx.size() - 3], vx[vx.size() - 2], vx[vx.size() - 1]});
    if (device == "gpu-emulated") {
      const std::string log = slurp(d + "/out/run.log");
      const auto at = log.find("the list guard stopped the device ");
      ASSERT_NE(at, std::string::npos) << log;
      const int stops = std::stoi(log.substr(at + 34));
      std::printf("[measured] list guard stops in the run: %d\n", stops);
      EXPECT_GE(stops, 1);
    }
  }
  ASSERT_EQ(last.size(), 2u);
  std::printf("[measured] final v_x cpu %.9g %.9g %.9g, gpu %.9g %.9g %.9g m/s\n", last[0][0], last[0][1], last[0][2],
              last[1][0], last[1][1], last[1][2]);
  EXPECT_LT(last[0][0], -0.5) << "the pair pushed apart";
  EXPECT_GT(last[0][2], 0.05) << "the third bead, beyond the skin at the start, was struck";
  for (int b = 0; b < 3; ++b) EXPECT_NEAR(last[1][b], last[0][b], 1e-9 * std::abs(last[0][0])) << "body " << b;

  // Stopped by SIGTERM and resumed, at step 1 (the resumed run makes the guard's stop) and at
  // step 700 (after the stop, between checkpoints): the bytes of the run above.
  for (const char* step : {"1", "700"}) {
    SCOPED_TRACE(std::string("SIGTERM at step ") + step);
    const std::string d = write_case(std::string("guard_run_sig_") + step);
    auto r = run_command("BIODEM_TEST_SIGNAL_AT_STEP=" + std::string(step) + " " + biodem_exe() + " run " + d +
                         "/case.toml --out " + d + "/out --threads 1 --device gpu-emulated");
    EXPECT_EQ(r.status, 143) << r.output;
    auto rr = run_command(biodem_exe() + " run " + d + "/case.toml --out " + d +
                          "/out --threads 1 --resume --device gpu-emulated");
    ASSERT_EQ(rr.status, 0) << rr.output;
    for (const char* f : {"/trace.csv", "/series.csv", "/checkpoint.bin"})
      EXPECT_EQ(slurp(full + f), slurp(d + "/out" + f)) << f;
    if (std::string(step) == "1") {
      const std::string log = slurp(d + "/out/run.log");
      const auto at = log.rfind("the list guard stopped the device ");
      ASSERT_NE(at, std::string::npos);
      EXPECT_GE(std::stoi(log.substr(at + 34)), 1) << "the resumed run stopped at the guard";
    }
  }

  // Without the guard: the half-skin stop.
  const std::string off = write_case("guard_run_off");
  auto ro = run_command("BIODEM_GPU_LIST_GUARD=0 " + biodem_exe() + " run " + off + "/case.toml --out " + off +
                        "/out --threads 1 --device gpu-emulated");
  EXPECT_NE(ro.status, 0) << ro.output;
  EXPECT_NE(ro.output.find("more than half the skin"), std::string::npos) << ro.output;
}
