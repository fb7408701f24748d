// `biodem run --device gpu-emulated` (the GPU engine's kernels on CPU threads) drives the whole
// run like the CPU engine: insertion waves, settle criterion, rotation, samples, snapshots,
// trace, checkpoints. Checked here through the binary, as a user runs it:
// - a short drum agrees with the CPU engine in alpha and kinetic energy;
// - a GPU run stopped abruptly at chosen steps and resumed continues bit for bit;
// - a GPU checkpoint resumes on the CPU engine and a CPU checkpoint on the GPU engine;
// - `--device gpu` without a GPU (or without the CUDA build) is one clear line, no outputs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>

#include "test_util.hpp"

using namespace biodem::testing;
namespace fs = std::filesystem;

namespace {
const std::string kCase = source_dir() + "/tests/cases/checkpoint_tiny.toml";
/// The GPU engine under test: its kernels on CPU threads by default (CI); BIODEM_TEST_GPU=1
/// runs the same tests on the CUDA device of a GPU machine.
std::string gpu_device() {
  const char* v = std::getenv("BIODEM_TEST_GPU");
  return v && std::string(v) == "1" ? "gpu" : "gpu-emulated";
}
const std::string kNeedles = source_dir() + "/tests/cases/gpu_needles_tiny.toml";

/// The list builds that run.log's phase lines report ("; N list builds"), summed over the phases,
/// and the run's total from the finished line (the device list's, or the CPU list's).
std::pair<long, long> phase_and_total_builds(const std::string& log, bool device) {
  long phases = 0, total = -1;
  for (std::size_t p = log.find("phase '"); p != std::string::npos; p = log.find("phase '", p + 1)) {
    const std::size_t eol = log.find('\n', p);
    const std::string line = log.substr(p, eol - p);
    if (line.find(" ends at t = ") == std::string::npos) continue;
    const std::size_t b = line.find("; ");
    const std::size_t q = line.find(" list builds");
    if (b == std::string::npos || q == std::string::npos) return {-1, -1};
    phases += std::stol(line.substr(line.rfind(' ', q - 1) + 1));
  }
  const std::string key = device ? "device neighbour builds " : "neighbour builds ";
  const std::size_t f = log.find("finished: ");
  const std::size_t t = f == std::string::npos ? f : log.find(key, f);
  if (t != std::string::npos) total = std::stol(log.substr(t + key.size()));
  return {phases, total};
}

void expect_same_outputs(const std::string& a, const std::string& b) {
  EXPECT_EQ(slurp(a + "/series.csv"), slurp(b + "/series.csv"));
  EXPECT_EQ(slurp(a + "/trace.csv"), slurp(b + "/trace.csv"));
  for (const char* pvd : {"/snapshots.pvd", "/bodies.pvd"}) EXPECT_EQ(slurp(a + pvd), slurp(b + pvd)) << pvd;
  for (const char* dir : {"/snapshots/", "/bodies/"})
    for (const auto& e : fs::directory_iterator(a + dir))
      EXPECT_EQ(slurp(e.path().string()), slurp(b + dir + e.path().filename().string()))
          << dir << e.path().filename();
}
}  // namespace

TEST(GpuRuns, SmallDrumAgreesWithCpuEngine) {
  const std::string c = fresh_dir("gpu_vs_cpu_cpu"), g = fresh_dir("gpu_vs_cpu_gpu");
  auto rc = run_command(biodem_exe() + " run " + kCase + " --out " + c + " --threads 1");
  ASSERT_EQ(rc.status, 0) << rc.output;
  auto rg = run_command(biodem_exe() + " run " + kCase + " --out " + g + " --threads 1 --device " + gpu_device());
  ASSERT_EQ(rg.status, 0) << rg.output;
  EXPECT_NE(slurp(g + "/run.log").find("engine: GPU engine on "), std::string::npos);
  EXPECT_NE(slurp(g + "/run.log").find("us/step"), std::string::npos);
  // Each phase line counts its list builds; with the build of the set-up (the first upload or
  // the first step's list), they add up to the run's total.
  for (const auto& [dir, device] : {std::pair{c, false}, std::pair{g, true}}) {
    const auto [phases, total] = phase_and_total_builds(slurp(dir + "/run.log"), device);
    EXPECT_GT(phases, 5) << dir;
    EXPECT_EQ(phases + 1, total) << dir;
  }
  const auto sc = read_csv(c + "/series.csv"), sg = read_csv(g + "/series.csv");
  const auto ac = to_numbers(sc.at("alpha_deg")), ag = to_numbers(sg.at("alpha_deg"));
  const auto kc = to_numbers(sc.at("kinetic_energy_j")), kg = to_numbers(sg.at("kinetic_energy_j"));
  ASSERT_EQ(ac.size(), ag.size());
  ASSERT_GT(ac.size(), 50u);
  double worst_alpha = 0.0, ke_sum_c = 0.0, ke_sum_g = 0.0;
  for (std::size_t k = 0; k < ac.size(); ++k) {
    worst_alpha = std::max(worst_alpha, std::abs(ac[k] - ag[k]));
    ke_sum_c += kc[k];
    ke_sum_g += kg[k];
  }
  std::printf("[measured] tiny drum (400 beads, %zu samples): worst |alpha_cpu - alpha_gpu| = %.3g deg, "
              "mean KE cpu %.6g J gpu %.6g J, final alpha %.4f vs %.4f\n",
              ac.size(), worst_alpha, ke_sum_c / ac.size(), ke_sum_g / ag.size(), ac.back(), ag.back());
  // The drum turns 0.06 revolution (21.6 deg) after settling; 0.5 deg is 2 % of that motion.
  EXPECT_LT(worst_alpha, 0.5);
  EXPECT_NEAR(ke_sum_g, ke_sum_c, 0.05 * ke_sum_c);
}

TEST(GpuRuns, StoppedGpuRunResumesBitForBit) {
  const std::string a = fresh_dir("gpu_ckpt_full");
  auto ra = run_command(biodem_exe() + " run " + kCase + " --out " + a + " --threads 1 --device " + gpu_device());
  ASSERT_EQ(ra.status, 0) << ra.output;
  // Stops after the first checkpoint (during settling), during settling between checkpoints,
  // and during rotation.
  for (const char* step : {"700", "2950", "5333"}) {
    const std::string b = fresh_dir(std::string("gpu_ckpt_stop_") + step);
    auto rk = run_command("BIODEM_TEST_ABORT_AT_STEP=" + std::string(step) + " " + biodem_exe() + " run " + kCase +
                          " --out " + b + " --threads 1 --device " + gpu_device());
    ASSERT_EQ(rk.status, 137) << "the run must stop at step " << step << ": " << rk.output;
    ASSERT_TRUE(fs::exists(b + "/checkpoint.bin"));
    auto rb = run_command(biodem_exe() + " run " + kCase + " --out " + b + " --threads 1 --device " + gpu_device() + " --resume");
    ASSERT_EQ(rb.status, 0) << rb.output;
    expect_same_outputs(a, b);
  }
}

// A checkpoint records the engine that wrote it and the GPU engine's family of contact sums
// (checkpoint version 6). A run of the order-free family (BIODEM_GPU_SUMS=fixed) killed and
// resumed without the variable goes on with the fixed sums: its outputs and final checkpoint are
// byte-identical to the uninterrupted fixed run (before, it went on with the ordered sums). With
// the variable set to the same family nothing is said; set to the other family the variable
// wins, and run.log says the outputs are then neither family's. A resume that would adopt the
// fixed sums beside BIODEM_GPU_SUM_LANES=1 (no such kernel set) is one line that says what to do.
TEST(GpuRuns, ResumedRunKeepsTheContactSumFamilyOfItsCheckpoint) {
  const std::string full = fresh_dir("gpu_fixed_full");
  auto rf = run_command("BIODEM_GPU_SUMS=fixed " + biodem_exe() + " run " + kNeedles + " --out " + full +
                        " --threads 1 --device " + gpu_device());
  ASSERT_EQ(rf.status, 0) << rf.output;
  int k = 0;
  for (const std::string resume_env : {"", "BIODEM_GPU_SUMS=fixed ", "BIODEM_GPU_SUMS=ordered ", "BIODEM_GPU_SUM_LANES=1 "}) {
    const std::string d = fresh_dir("gpu_fixed_resumed_" + std::to_string(k++));
    auto rk = run_command("BIODEM_TEST_ABORT_AT_STEP=9001 BIODEM_GPU_SUMS=fixed " + biodem_exe() + " run " + kNeedles +
                          " --out " + d + " --threads 1 --device " + gpu_device());
    ASSERT_EQ(rk.status, 137) << rk.output;
    auto rr = run_command(resume_env + biodem_exe() + " run " + kNeedles + " --out " + d + " --threads 1 --device " +
                          gpu_device() + " --resume");
    if (resume_env == "BIODEM_GPU_SUM_LANES=1 ") {
      EXPECT_EQ(rr.status, 2) << rr.output;
      EXPECT_NE(rr.output.find("which have no kernel set for BIODEM_GPU_SUM_LANES = '1'; unset it, or set "
                               "BIODEM_GPU_SUMS=ordered to go on with the ordered sums"),
                std::string::npos)
          << rr.output;
      continue;
    }
    ASSERT_EQ(rr.status, 0) << rr.output;
    const std::string log = slurp(d + "/run.log");
    const std::string resumed = log.substr(log.find("resumed from checkpoint.bin"));
    const bool fixed_on = resumed.find("with fixed-point sums in any order") != std::string::npos;
    const std::string adopted = "GPU contact sums: fixed, as " + d + "/checkpoint.bin was written (BIODEM_GPU_SUMS unset)";
    if (resume_env == "BIODEM_GPU_SUMS=ordered ") {
      EXPECT_NE(resumed.find("was written with the GPU engine's fixed contact sums; this run goes on with the ordered "
                             "ones (BIODEM_GPU_SUMS): the outputs from here on are those of neither family's "
                             "uninterrupted run"),
                std::string::npos)
          << log;
      EXPECT_FALSE(fixed_on) << resumed;
    } else {
      EXPECT_EQ(resumed.find(adopted) != std::string::npos, resume_env.empty()) << log;
      EXPECT_EQ(resumed.find("note: "), std::string::npos) << log;
      EXPECT_TRUE(fixed_on) << resumed;
      expect_same_outputs(full, d);
      EXPECT_EQ(slurp(full + "/checkpoint.bin"), slurp(d + "/checkpoint.bin"));
    }
    EXPECT_EQ(log.find("was written by the"), std::string::npos) << log;  // same engine: no engine note
  }
}

// The settle criterion is evaluated on the device from the phase step and the counter of steps
// below the threshold that a checkpoint holds: a run killed while the bed is below the threshold
// but not yet for the whole hold time, and resumed, ends the settle phase at the same step with
// byte-identical outputs. biomass_9_6_quick settles on the criterion at step 11,011 (hold 0.01 s =
// 667 steps, so below the threshold from step 10,345 on); with a checkpoint every 0.1605 s
// (10,700 steps) the checkpoint at step 10,700 falls inside that window, and the run is killed at
// step 10,750.
TEST(GpuRuns, SettleCriterionResumesInsideTheHoldWindow) {
  std::string text = slurp(source_dir() + "/tests/cases/biomass_9_6_quick.toml");
  const std::string every = "checkpoint_every_s = 0.5";
  const auto at = text.find(every);
  ASSERT_NE(at, std::string::npos);
  text.replace(at, every.size(), "checkpoint_every_s = 0.1605");
  const std::string c = (fs::current_path() / "gpu_settle_resume.toml").string();
  std::ofstream(c) << text;
  const std::string full = fresh_dir("gpu_settle_full"), d = fresh_dir("gpu_settle_killed");
  auto rf = run_command(biodem_exe() + " run " + c + " --out " + full + " --threads 1 --device " + gpu_device());
  ASSERT_EQ(rf.status, 0) << rf.output;
  auto settle_end = [](const std::string& log) {
    const auto p = log.find("phase 'settle' ends at t = ");
    return p == std::string::npos ? std::string() : log.substr(p, log.find(" s after", p) - p);
  };
  const std::string log_full = slurp(full + "/run.log");
  ASSERT_NE(log_full.find("phase 'settle' ends at t = 0.165165 s after 11011 steps"), std::string::npos)
      << "the case must settle on the criterion at step 11,011 for the window above to hold\n" << log_full;
  ASSERT_NE(log_full.find("(settled: mean kinetic energy below threshold)"), std::string::npos);
  auto rk = run_command("BIODEM_TEST_ABORT_AT_STEP=10750 " + biodem_exe() + " run " + c + " --out " + d +
                        " --threads 1 --device " + gpu_device());
  ASSERT_EQ(rk.status, 137) << rk.output;
  auto rr = run_command(biodem_exe() + " run " + c + " --out " + d + " --threads 1 --device " + gpu_device() + " --resume");
  ASSERT_EQ(rr.status, 0) << rr.output;
  const std::string log_resumed = slurp(d + "/run.log");
  EXPECT_NE(log_resumed.find("resumed from checkpoint.bin at t = 0.1605 s (step 10700)"), std::string::npos) << log_resumed;
  EXPECT_NE(log_resumed.find("phase 1 'settle' resumes"), std::string::npos) << log_resumed;
  // The resumed log has the killed run's "settle starts" and the resumed run's "settle ends".
  EXPECT_EQ(settle_end(log_resumed), settle_end(log_full));
  expect_same_outputs(full, d);
  EXPECT_EQ(slurp(full + "/checkpoint.bin"), slurp(d + "/checkpoint.bin"));
}

TEST(GpuRuns, CheckpointsMoveBetweenDevices) {
  // Reference runs on each engine, then each stopped and resumed on the other engine.
  const std::string cpu = fresh_dir("xdev_cpu"), gpu = fresh_dir("xdev_gpu");
  ASSERT_EQ(run_command(biodem_exe() + " run " + kNeedles + " --out " + cpu + " --threads 1").status, 0);
  ASSERT_EQ(run_command(biodem_exe() + " run " + kNeedles + " --out " + gpu + " --threads 1 --device " + gpu_device()).status, 0);
  const auto a_cpu = to_numbers(read_csv(cpu + "/series.csv").at("alpha_deg"));
  const auto a_gpu = to_numbers(read_csv(gpu + "/series.csv").at("alpha_deg"));
  ASSERT_FALSE(a_cpu.empty());
  ASSERT_EQ(a_cpu.size(), a_gpu.size());
  // Stopped during the rotation, 1,001 steps after the checkpoint at step 8,000.
  const std::string stop = "9001";
  for (const auto& [first, second, ref] : {std::tuple<std::string, std::string, std::vector<double>>{gpu_device(), "cpu", a_gpu},
                                           {"cpu", gpu_device(), a_cpu}}) {
    const std::string d = fresh_dir("xdev_" + first + "_to_" + second);
    auto rk = run_command("BIODEM_TEST_ABORT_AT_STEP=" + stop + " " + biodem_exe() + " run " + kNeedles + " --out " + d +
                          " --threads 1 --device " + first);
    ASSERT_EQ(rk.status, 137) << rk.output;
    auto rr = run_command(biodem_exe() + " run " + kNeedles + " --out " + d + " --threads 1 --resume --device " + second);
    ASSERT_EQ(rr.status, 0) << rr.output;
    // run.log says which engine wrote the checkpoint and which goes on.
    EXPECT_NE(slurp(d + "/run.log").find("was written by the " + first + " engine; this run goes on with the " + second +
                                         " engine from its state"),
              std::string::npos)
        << slurp(d + "/run.log");
    const auto a = to_numbers(read_csv(d + "/series.csv").at("alpha_deg"));
    ASSERT_EQ(a.size(), ref.size());
    double worst = 0.0;
    for (std::size_t k = 0; k < a.size(); ++k) worst = std::max(worst, std::abs(a[k] - ref[k]));
    std::printf("[measured] needles %s -> %s at step %s: worst |alpha - alpha_%s| = %.3g deg over %zu samples\n",
                first.c_str(), second.c_str(), stop.c_str(), first.c_str(), worst, a.size());
    // A resumed run continues the same bed (the engines differ only in summation order); a lost
    // contact history or a wrong sign would jolt the cohesive needle bed by degrees.
    EXPECT_LT(worst, 0.5);
  }
}

TEST(GpuRuns, GpuWithoutGpuIsOneClearLine) {
  const std::string d = fresh_dir("gpu_missing");
  auto r = run_command(biodem_exe() + " run " + kCase + " --out " + d + " --device gpu");
  if (r.status == 0) GTEST_SKIP() << "this machine has a GPU and a CUDA build: nothing to refuse";
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("--device gpu"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("internal error"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(d + "/series.csv")) << "nothing may be computed or written";
  auto rb = run_command(biodem_exe() + " run " + kCase + " --out " + d + " --device tpu");
  EXPECT_NE(rb.status, 0);
  // Asked for by the case ([run] device), the line names the case's key, not an option that was
  // not given.
  const std::string with_key = d + "/gpu_case.toml";
  fs::create_directories(d);
  {
    std::string text = slurp(kCase);
    const std::size_t run = text.find("[run]\n");
    ASSERT_NE(run, std::string::npos);
    text.insert(run + 6, "device = \"gpu\"\n");
    std::ofstream(with_key) << text;
  }
  auto rk = run_command(biodem_exe() + " run " + with_key + " --out " + d + "/k");
  EXPECT_EQ(rk.status, 2) << rk.output;
  EXPECT_NE(rk.output.find("gpu_case.toml: [run] device = \"gpu\": "), std::string::npos) << rk.output;
  EXPECT_EQ(rk.output.find("--device"), std::string::npos) << rk.output;
  EXPECT_FALSE(fs::exists(d + "/k/series.csv"));
}

// More walls than the GPU engine takes (16): refused in one line before anything is written,
// naming the case's key when the case asked for the engine (before, the refusal came at the
// upload after insertion, and named --device either way).
TEST(GpuRuns, TooManyWallsAreRefusedBeforeTheRun) {
  const std::string d = fresh_dir("gpu_walls17");
  fs::create_directories(d);
  std::string text = slurp(kCase);
  for (int k = 0; k < 14; ++k)  // + the drum's 3 = 17, all far below the drum
    text += "\n[[wall]]\nkind = \"plane\"\npoint_m = [0.0, " + std::to_string(-1.0 - k) +
            ", 0.0]\nnormal = [0.0, 1.0, 0.0]\nmaterial = \"steel\"\n";
  std::ofstream(d + "/walls.toml") << text;
  std::string keyed = text;
  keyed.insert(keyed.find("[run]\n") + 6, "device = \"gpu-emulated\"\n");
  std::ofstream(d + "/walls_key.toml") << keyed;
  auto r = run_command(biodem_exe() + " run " + d + "/walls.toml --out " + d + "/a --device gpu-emulated");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("--device gpu: the scene has 17 walls"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(d + "/a/series.csv"));
  r = run_command(biodem_exe() + " run " + d + "/walls_key.toml --out " + d + "/b");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("walls_key.toml: [run] device = \"gpu-emulated\": the scene has 17 walls"), std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(d + "/b/series.csv"));
  EXPECT_EQ(run_command(biodem_exe() + " check " + d + "/walls.toml").status, 0) << "the CPU engine takes them";
}

// The GPU engine's switches (docs/gpu.md, "Switches"): a value outside the documented ones stops
// the run with status 2 and one line naming the variable, before anything is written.
// (BIODEM_GPU_BLOCK is read by the CUDA engine only.)
TEST(GpuRuns, BadSwitchesStopWithOneLineNamingThem) {
  for (const std::string bad : {"BIODEM_GPU_FORCES=rowz", "BIODEM_GPU_SKIN_DIAMETERS=0", "BIODEM_GPU_SKIN_DIAMETERS=2.5",
                                "BIODEM_GPU_CHECK_EVERY=65", "BIODEM_GPU_CHECK_EVERY=0", "BIODEM_GPU_SORT=-1",
                                "BIODEM_GPU_FUSE=2", "BIODEM_GPU_PROFILE=yes", "BIODEM_GPU_FORCES=fast",
                                "BIODEM_GPU_QUEUED_CHECK=2", "BIODEM_TEST_GPU_FAULT_AT_STEP=x",
                                "BIODEM_TEST_GPU_FAULT_AT_STEP=0", "BIODEM_GPU_BLOCK=100", "BIODEM_GPU_ROW_LANES=3",
                                "BIODEM_GPU_BUILD_LANES=0", "BIODEM_GPU_BUILD_LANES=64",
                                "BIODEM_TEST_GPU_FAULT_IN_THRUST=2", "BIODEM_GPU_SUM_LANES=2", "BIODEM_GPU_WALK_KICK=yes",
                                "BIODEM_GPU_PDL=on", "BIODEM_GPU_SUMS=sorted",
                                "BIODEM_GPU_SUMS=fixed BIODEM_GPU_SUM_LANES=1",
                                "BIODEM_GPU_SUMS=fixed BIODEM_GPU_WALK_KICK=1", "BIODEM_GPU_PAIR_LIST=short",
                                "BIODEM_GPU_RECORDS=2", "BIODEM_GPU_OWN_SPHERE=yes", "BIODEM_GPU_BODY_LANES=3",
                                "BIODEM_GPU_WALK_PACK=2", "BIODEM_GPU_PACK_SPLIT=3"}) {
    const std::string d = fresh_dir("gpu_bad_switch");
    auto r = run_command(bad + " " + biodem_exe() + " run " + kNeedles + " --out " + d + " --device " + gpu_device());
    const std::string name = bad.substr(0, bad.find('='));
    EXPECT_EQ(r.status, 2) << bad << ": " << r.output;
    EXPECT_NE(r.output.find(name + " = '"), std::string::npos) << bad << ": " << r.output;
    EXPECT_FALSE(fs::exists(d + "/series.csv")) << bad << ": nothing may be computed or written";
    EXPECT_FALSE(fs::exists(d + "/run.log")) << bad;
  }
  const std::string ok = fresh_dir("gpu_good_switch");  // the documented values run
  auto r = run_command("BIODEM_GPU_FORCES=rows BIODEM_GPU_SKIN_DIAMETERS=0.5 BIODEM_GPU_CHECK_EVERY=20 "
                       "BIODEM_GPU_BUILD_LANES=1 BIODEM_GPU_SUM_LANES=auto BIODEM_GPU_WALK_KICK=1 BIODEM_GPU_PDL=0 "
                       "BIODEM_GPU_RECORDS=1 BIODEM_GPU_OWN_SPHERE=1 BIODEM_GPU_BODY_LANES=auto BIODEM_GPU_WALK_PACK=1 "
                       "BIODEM_GPU_PACK_SPLIT=2 " +
                       biodem_exe() +
                       " run " + kNeedles + " --out " + ok + " --device " + gpu_device());
  EXPECT_EQ(r.status, 0) << r.output;
  // (run.log says how the spheres were read and the needles' bodies were updated: in the walk,
  // by groups of 4 lanes, so the body kernel's lanes go unused)
  const std::string how = slurp(ok + "/run.log");
  EXPECT_NE(how.find("BIODEM_GPU_RECORDS=1"), std::string::npos) << how;
  EXPECT_NE(how.find("in groups of 4 lanes per body (ForcesKickDriftGroups"), std::string::npos) << how;
  EXPECT_NE(how.find("BIODEM_GPU_BODY_LANES unused (the walk with the body update"), std::string::npos) << how;
  EXPECT_NE(how.find("share their touching contacts across its lanes (BIODEM_GPU_WALK_PACK=1"), std::string::npos) << how;
  EXPECT_NE(how.find("BIODEM_GPU_PACK_SPLIT unused (the clumps' walk with the body update"), std::string::npos) << how;
  const std::string fixed = fresh_dir("gpu_fixed_sums");  // the order-free family runs and says so
  r = run_command("BIODEM_GPU_SUMS=fixed BIODEM_GPU_FORCES=auto " + biodem_exe() + " run " + kNeedles + " --out " +
                  fixed + " --device " + gpu_device());
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(slurp(fixed + "/run.log").find("fixed-point sums in any order"), std::string::npos)
      << slurp(fixed + "/run.log");
  const std::string fixed_rows = fresh_dir("gpu_fixed_sums_rows");  // and its row walk
  r = run_command("BIODEM_GPU_SUMS=fixed BIODEM_GPU_FORCES=rows BIODEM_GPU_PAIR_LIST=full " + biodem_exe() + " run " +
                  kNeedles + " --out " + fixed_rows + " --device " + gpu_device());
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(slurp(fixed_rows + "/run.log").find("ForcesFixed"), std::string::npos) << slurp(fixed_rows + "/run.log");
}

// The switches the CUDA engine applies (BIODEM_GPU_BLOCK, BIODEM_GPU_ROW_LANES, BIODEM_GPU_BUILD_LANES,
// BIODEM_GPU_PDL) are checked
// before the engine looks for a device, whatever the build: with `--device gpu` a bad value is
// one line naming it (before "no CUDA-capable GPU" or "built without the CUDA engine"), and
// nothing is written.
TEST(GpuRuns, CudaSwitchesAreCheckedBeforeTheDevice) {
  for (const std::string bad : {"BIODEM_GPU_BLOCK=100", "BIODEM_GPU_ROW_LANES=3", "BIODEM_GPU_ROW_LANES=64",
                                "BIODEM_GPU_BUILD_LANES=3", "BIODEM_GPU_PDL=2"}) {
    const std::string d = fresh_dir("gpu_bad_cuda_switch");
    auto r = run_command(bad + " " + biodem_exe() + " run " + kNeedles + " --out " + d + " --device gpu");
    const std::string name = bad.substr(0, bad.find('='));
    EXPECT_EQ(r.status, 2) << bad << ": " << r.output;
    EXPECT_NE(r.output.find(name + " = '"), std::string::npos) << bad << ": " << r.output;
    EXPECT_FALSE(fs::exists(d + "/run.log")) << bad;
  }
}

namespace {
/// A run ended by a device fault: status 2 and one "biodem: error: GPU engine:" line (on CPU
/// threads the injected fault's own), no fallback line (a queued check or graph given up as if
/// the run could go on), no std::terminate. On a GPU the fault may surface first in a Thrust
/// call: the engine names its CUDA error as its own (not "internal error"; gpu_check 3h forces
/// that case).
void expect_one_fault_line(const CommandResult& r) {
  EXPECT_EQ(r.status, 3) << r.output;  // (a device fault: status 3, as an internal error)
  EXPECT_NE(r.output.find("biodem: error: GPU engine: "), std::string::npos) << r.output;
  if (gpu_device() == "gpu-emulated") {
    EXPECT_NE(r.output.find("biodem: error: GPU engine: a kernel faulted on the device"), std::string::npos)
        << r.output;
  }
  EXPECT_EQ(r.output.find("for the rest of the run"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("terminate called"), std::string::npos) << r.output;
}
}  // namespace

// A fault on the device (test hook BIODEM_TEST_GPU_FAULT_AT_STEP: on a GPU a kernel that traps
// and breaks the CUDA context; on CPU threads the error such a fault gives) ends the run with
// one error line, not std::terminate, and the run resumes from its last checkpoint to the same
// bytes as a run without the fault.
TEST(GpuRuns, DeviceFaultEndsTheRunWithOneLineAndItResumes) {
  const std::string whole = fresh_dir("gpu_fault_whole"), d = fresh_dir("gpu_fault");
  auto r0 = run_command(biodem_exe() + " run " + kNeedles + " --out " + whole + " --device " + gpu_device());
  ASSERT_EQ(r0.status, 0) << r0.output;
  auto r1 = run_command("BIODEM_TEST_GPU_FAULT_AT_STEP=3000 " + biodem_exe() + " run " + kNeedles + " --out " + d +
                        " --device " + gpu_device());
  expect_one_fault_line(r1);
  EXPECT_EQ(r1.output.find("done: "), std::string::npos) << "the run must stop: " << r1.output;
  ASSERT_TRUE(fs::exists(d + "/checkpoint.bin"));
  auto r2 = run_command(biodem_exe() + " run " + kNeedles + " --out " + d + " --resume --device " + gpu_device());
  ASSERT_EQ(r2.status, 0) << r2.output;
  expect_same_outputs(whole, d);
  EXPECT_EQ(slurp(whole + "/checkpoint.bin"), slurp(d + "/checkpoint.bin"));
}

// The same fault inside a settle phase ended by the kinetic energy criterion on the device: the
// settle poll's queued copy meets it first (on CPU threads; on a GPU whichever wait comes
// first), and its fallback must not take it for an error the run can go on from.
TEST(GpuRuns, DeviceFaultInASettleCriterionPhaseEndsTheRun) {
  const std::string d = fresh_dir("gpu_fault_settle");
  auto r = run_command("BIODEM_TEST_GPU_FAULT_AT_STEP=3000 " + biodem_exe() + " run " + source_dir() +
                       "/tests/cases/biomass_9_6_quick.toml --out " + d + " --device " + gpu_device());
  expect_one_fault_line(r);
  EXPECT_EQ(slurp(d + "/run.log").find("phase 'settle' ends"), std::string::npos) << "the run must stop in the settle phase";
}

// BIODEM_GPU_PROFILE=1 adds one line to run.log saying where the steps' wall time went (step
// kernels, list checks, list builds, the rest) and changes no result: the needle drum's outputs
// and checkpoint byte-identical to a run without it; the parts add up to the whole (to the
// rounding of the line's figures), every step is counted, and the builds timed are those the
// list checks made (the run's device builds less the one of each upload).
TEST(GpuRuns, ProfileLineAddsUpAndChangesNothing) {
  const std::string plain = fresh_dir("gpu_profile_off"), prof = fresh_dir("gpu_profile_on");
  auto r0 = run_command(biodem_exe() + " run " + kNeedles + " --out " + plain + " --device " + gpu_device());
  ASSERT_EQ(r0.status, 0) << r0.output;
  auto r1 = run_command("BIODEM_GPU_PROFILE=1 " + biodem_exe() + " run " + kNeedles + " --out " + prof + " --device " +
                        gpu_device());
  ASSERT_EQ(r1.status, 0) << r1.output;
  expect_same_outputs(plain, prof);
  EXPECT_EQ(slurp(plain + "/checkpoint.bin"), slurp(prof + "/checkpoint.bin"));
  EXPECT_EQ(slurp(plain + "/run.log").find("GPU profile"), std::string::npos);
  const std::string log = slurp(prof + "/run.log");
  const auto at = log.find("GPU profile (BIODEM_GPU_PROFILE=1), us per step over ");
  ASSERT_NE(at, std::string::npos) << log;
  unsigned long long steps = 0, between = 0, checks = 0, builds = 0;
  double all = 0, kernels = 0, check_us = 0, check_each = 0, build_us = 0, build_each = 0, rest = 0;
  const int got = std::sscanf(log.c_str() + at,
                              "GPU profile (BIODEM_GPU_PROFILE=1), us per step over %llu steps: %lf in all = step "
                              "kernels %lf (%llu steps between checks) + list checks %lf (%llu, %lf us each) + list "
                              "builds %lf (%llu, %lf us each) + the rest %lf",
                              &steps, &all, &kernels, &between, &check_us, &checks, &check_each, &build_us, &builds,
                              &build_each, &rest);
  ASSERT_EQ(got, 11) << log.substr(at);
  EXPECT_EQ(steps, 14000u);  // the case's 8,000 + 6,000 steps
  EXPECT_GT(between, steps * 8 / 10);
  EXPECT_LE(between, steps);
  EXPECT_NEAR(kernels + check_us + build_us + rest, all, 0.05);
  EXPECT_GE(rest, -0.02) << "a part timed twice";
  // (the figures are rounded to 0.01 us: the totals agree within that times the counts)
  EXPECT_NEAR(check_us * static_cast<double>(steps), check_each * static_cast<double>(checks),
              0.005 * static_cast<double>(steps + checks));
  EXPECT_NEAR(build_us * static_cast<double>(steps), build_each * static_cast<double>(builds),
              0.005 * static_cast<double>(steps + builds));
  EXPECT_GE(checks, steps / 10);  // at most 10 steps between two checks
  unsigned long long device_builds = 0;
  const auto db = log.find("device neighbour builds ");
  ASSERT_NE(db, std::string::npos);
  ASSERT_EQ(std::sscanf(log.c_str() + db, "device neighbour builds %llu", &device_builds), 1);
  EXPECT_GT(builds, 0u);
  EXPECT_LT(builds, device_builds);  // the uploads' builds are outside the steps
  EXPECT_GE(builds + 3, device_builds);
}

// BIODEM_GPU_FORCES=timed (the default on a GPU): after each upload, at each phase start and
// every 20,000 steps the runs of steps between list checks go through the scene's candidate
// sets, timed (those far slower than the fastest dropped after one run), and the fastest runs
// on. Whatever it picks, the outputs and checkpoint are byte-identical to a run with the row
// walk fixed, and run.log names the set that ran and every set's median; the default on CPU
// threads says it chose by sphere count.
TEST(GpuRuns, TimedKernelChoiceChangesNothing) {
  const std::string rows = fresh_dir("gpu_forces_rows"), timed = fresh_dir("gpu_forces_timed"),
                    dflt = fresh_dir("gpu_forces_default");
  auto r0 = run_command("BIODEM_GPU_FORCES=rows " + biodem_exe() + " run " + kNeedles + " --out " + rows +
                        " --device " + gpu_device());
  ASSERT_EQ(r0.status, 0) << r0.output;
  auto r1 = run_command("BIODEM_GPU_FORCES=timed " + biodem_exe() + " run " + kNeedles + " --out " + timed +
                        " --device " + gpu_device());
  ASSERT_EQ(r1.status, 0) << r1.output;
  auto r2 = run_command(biodem_exe() + " run " + kNeedles + " --out " + dflt + " --device " + gpu_device());
  ASSERT_EQ(r2.status, 0) << r2.output;
  for (const std::string& d : {timed, dflt}) {
    expect_same_outputs(rows, d);
    EXPECT_EQ(slurp(rows + "/checkpoint.bin"), slurp(d + "/checkpoint.bin")) << d;
  }
  const std::string log = slurp(timed + "/run.log");
  const auto at = log.find("GPU contact kernels: ");
  ASSERT_NE(at, std::string::npos) << log;
  const std::string line = log.substr(at, log.find('\n', at) - at);
  EXPECT_NE(line.find("when the sets were last timed, over"), std::string::npos) << line;
  double entries_us = -1, rows_us = -1;
  const auto m = line.find("per-contact ", line.find("dropped after its run in it)"));
  ASSERT_NE(m, std::string::npos) << line;
  ASSERT_EQ(std::sscanf(line.c_str() + m, "per-contact %lf us/step, row walk %lf us/step", &entries_us, &rows_us), 2)
      << line;
  EXPECT_GT(entries_us, 0.0);
  EXPECT_GT(rows_us, 0.0);
  // Every set timed, "name: median us/step", with "(chosen)" after the set picked and "(dropped
  // after one run)" after those dropped after the first round (gpu/timed_choice.hpp). This
  // needle drum has eleven: per-contact with the sums in one thread and by the row lanes; the
  // row walk with the row lanes; in one thread, alone, with the warp's touching contacts shared,
  // with the body kernel by lanes, with both, with the contacts shared by 2 and by 4 lanes per
  // sphere (4: its 90 needles' spheres, four lanes each, fit in one wave of an H100); and in one thread
  // with the body update by groups of 4 lanes per body, with and without the contacts shared.
  const auto list_at = line.find("each set: [");
  ASSERT_NE(list_at, std::string::npos) << line;
  const std::string list = line.substr(list_at + 11, line.find("] (", list_at) - list_at - 11);
  struct Timed {
    std::string name;
    double us;
    bool chosen, dropped;
  };
  std::vector<Timed> timed_sets;
  for (std::size_t from = 0; from <= list.size();) {
    std::size_t to = list.find("; ", from);
    if (to == std::string::npos) to = list.size();
    const std::string item = list.substr(from, to - from);
    const auto colon = item.rfind(": ", item.find(" us/step"));
    EXPECT_NE(colon, std::string::npos) << item;
    if (colon != std::string::npos)
      timed_sets.push_back({item.substr(0, colon), std::atof(item.c_str() + colon + 2),
                            item.find("(chosen)") != std::string::npos, item.find("dropped") != std::string::npos});
    from = to + 2;
  }
  ASSERT_EQ(timed_sets.size(), 11u) << list;
  double best_entries = 1e30, best_walk = 1e30, chosen_us = -1;
  int chosen = 0, dropped = 0, shared = 0, body_lanes = 0, kick = 0;
  bool chose_entries = false;
  for (const Timed& t : timed_sets) {
    const bool entries = t.name.rfind("per-contact", 0) == 0;
    (entries ? best_entries : best_walk) = std::min(entries ? best_entries : best_walk, t.us);
    if (t.chosen) {
      ++chosen;
      chosen_us = t.us;
      chose_entries = entries;
    }
    dropped += t.dropped;
    shared += t.name.find("touching contacts shared across the warp") != std::string::npos;
    body_lanes += t.name.find("the body kernel by 4 lanes per body") != std::string::npos;
    kick += t.name.find("with the body update in groups of 4 lanes per body") != std::string::npos;
  }
  EXPECT_EQ(chosen, 1) << list;
  EXPECT_EQ(shared, 5) << list;
  for (const char* split : {"shared across the warp by 2 lanes per sphere", "shared across the warp by 4 lanes per sphere"})
    EXPECT_EQ(std::count_if(timed_sets.begin(), timed_sets.end(),
                            [split](const Timed& t) { return t.name.find(split) != std::string::npos; }),
              1)
        << split << " in " << list;
  EXPECT_EQ(body_lanes, 2) << list;
  EXPECT_EQ(kick, 2) << list;
  EXPECT_NEAR(entries_us, best_entries, 0.006) << line;
  EXPECT_NEAR(rows_us, best_walk, 0.006) << line;
  // The set picked is the fastest of those kept (figures rounded to 0.01), and run.log's first
  // words name its kind.
  for (const Timed& t : timed_sets) {
    if (!t.dropped) {
      EXPECT_LE(chosen_us, t.us + 0.011) << t.name << " in " << list;
    }
  }
  EXPECT_EQ(line.find("GPU contact kernels: per-contact") == 0, chose_entries) << line;
  std::printf("[measured] %zu sets timed, %d dropped after their first run\n", timed_sets.size(), dropped);
  if (gpu_device() == "gpu-emulated") {
    EXPECT_NE(slurp(dflt + "/run.log").find("by the sphere count"), std::string::npos);
  }
}

// The device stores the bodies sorted by neighbour-list cell (docs/gpu.md); downloads and
// checkpoints map them back to the host's order, and no result depends on the storage order.
// The cohesive needle drum with the bodies sorted at every list build (BIODEM_GPU_SORT=1), at
// every 4th (the default) and never (BIODEM_GPU_SORT=0): outputs and the final checkpoint
// byte-identical; then the sorted run killed after step 9,001 (1,001 steps after its checkpoint
// at step 8,000) and resumed, once sorted and once unsorted: byte-identical too. (Emulated, and
// BIODEM_TEST_GPU=1 on a GPU.)
TEST(GpuRuns, BodySortLeavesOutputsAndCheckpointsUnchanged) {
  auto run = [](const std::string& env, const std::string& out, const std::string& extra) {
    return run_command(env + " " + biodem_exe() + " run " + kNeedles + " --out " + out + " --threads 1 --device " +
                       gpu_device() + extra);
  };
  const std::string never = fresh_dir("gpu_sort_never"), every = fresh_dir("gpu_sort_every"),
                    fourth = fresh_dir("gpu_sort_default");
  auto r0 = run("BIODEM_GPU_SORT=0", never, "");
  ASSERT_EQ(r0.status, 0) << r0.output;
  auto r1 = run("BIODEM_GPU_SORT=1", every, "");
  ASSERT_EQ(r1.status, 0) << r1.output;
  auto r4 = run("", fourth, "");
  ASSERT_EQ(r4.status, 0) << r4.output;
  for (const std::string& d : {every, fourth}) {
    expect_same_outputs(never, d);
    EXPECT_EQ(slurp(never + "/checkpoint.bin"), slurp(d + "/checkpoint.bin")) << d;
  }
  for (const char* resume_env : {"BIODEM_GPU_SORT=1", "BIODEM_GPU_SORT=0"}) {
    const std::string d = fresh_dir(std::string("gpu_sort_resume_") + resume_env[16]);
    auto rk = run("BIODEM_GPU_SORT=1 BIODEM_TEST_ABORT_AT_STEP=9001", d, "");
    ASSERT_EQ(rk.status, 137) << rk.output;
    ASSERT_TRUE(fs::exists(d + "/checkpoint.bin"));
    auto rr = run(resume_env, d, " --resume");
    ASSERT_EQ(rr.status, 0) << rr.output;
    expect_same_outputs(never, d);
    EXPECT_EQ(slurp(never + "/checkpoint.bin"), slurp(d + "/checkpoint.bin")) << resume_env;
  }
}
