// Kill-and-resume at chosen steps (test hooks BIODEM_TEST_ABORT_AT_STEP: the process ends as
// after SIGKILL; BIODEM_TEST_SIGNAL_AT_STEP: SIGTERM, checkpoint, exit 143) where the older tests
// never stopped a run:
// - during insertion in waves (issue 10, item 5): the checkpoint carries the insertion state
//   (particles placed, waves, the random generator, the step of the fall between waves);
// - the bulk tests (issue 9): a [heap] killed while pouring, while the poured beads settle, while
//   the cylinder is lifted and while the heap comes to rest; a [bulk_density] killed while
//   pouring, while filling and on its last step (before the strike-off); a [shear_box] killed
//   while pouring, filling, while the gate is lifted and while the flow comes to rest.
// Every resumed run must end with the outputs of the uninterrupted run, byte for byte: series.csv,
// trace.csv, both .pvd files, every .vtu, responses.csv. Each kill is checked to have happened
// where it was aimed (run.log of the killed run), so the test cannot pass without testing it.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "test_util.hpp"

using namespace biodem::testing;
namespace fs = std::filesystem;

namespace {

const std::string kWaves = source_dir() + "/tests/cases/insertion_waves_tiny.toml";
const std::string kHeap = source_dir() + "/tests/cases/heap_resume_tiny.toml";

/// A tests/cases bulk test with the output cadence of heap_resume_tiny.toml (samples every 200
/// steps, snapshots every 2000, checkpoints every 400, trace on), written next to the test outputs.
std::string with_resume_outputs(const std::string& tiny, const std::string& name) {
  std::string text = slurp(source_dir() + "/tests/cases/" + tiny);
  const std::string old_out = "sample_hz = 50.0";
  const auto at = text.find(old_out);
  if (at == std::string::npos) return "";
  text.replace(at, old_out.size(),
               "sample_hz = 200.0\nsnapshot_every_s = 0.05\ncheckpoint_every_s = 0.01\ntrace = true");
  const std::string path = (fs::current_path() / (name + ".toml")).string();
  std::ofstream(path) << text;
  return path;
}

struct Kill {
  bool abort;          // true: BIODEM_TEST_ABORT_AT_STEP (exit 137); false: SIGTERM (exit 143)
  std::uint64_t step;  // 0: the last step of the run
  std::string where;   // "insert" or the name of the phase in progress at that step
};

std::string run_cmd(const std::string& case_file, const std::string& dir, const std::string& device) {
  return biodem_exe() + " run " + case_file + " --out " + dir + " --threads 1 --device " + device;
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

/// Where a run stood when it stopped, from its run.log: "insert" before the line that ends the
/// insertion ("bodies: ..."), else the phase started last and not ended, else "between".
std::string where_stopped(const std::string& log) {
  if (log.find("\nbodies: ") == std::string::npos) return "insert";
  const auto at = log.rfind("' starts at t = ");
  if (at == std::string::npos) return "between";
  const auto q = log.rfind('\'', at - 1);
  const std::string name = log.substr(q + 1, at - q - 1);
  return log.find("phase '" + name + "' ends") == std::string::npos ? name : "between";
}

/// The same files with the same bytes: series, trace, pvd lists, every snapshot, responses.
void expect_same_outputs(const std::string& a, const std::string& b, const std::string& label) {
  for (const char* f : {"series.csv", "trace.csv", "snapshots.pvd", "bodies.pvd", "responses.csv"}) {
    EXPECT_EQ(fs::exists(a + "/" + f), fs::exists(b + "/" + f)) << label << ": " << f;
    EXPECT_TRUE(slurp(a + "/" + f) == slurp(b + "/" + f)) << label << ": " << f << " differs";
  }
  for (const std::string dir : {"snapshots", "bodies"}) {  // spheres, and bodies in a folder of their own
    std::set<std::string> fa, fb;
    for (const auto& e : fs::directory_iterator(a + "/" + dir)) fa.insert(e.path().filename().string());
    for (const auto& e : fs::directory_iterator(b + "/" + dir)) fb.insert(e.path().filename().string());
    EXPECT_EQ(fa, fb) << label << ": " << dir << " files";
    EXPECT_GE(fa.size(), 2u) << label << ": " << dir;
    for (const auto& f : fa)
      EXPECT_TRUE(slurp(a + "/" + dir + "/" + f) == slurp(b + "/" + dir + "/" + f)) << label << ": " << dir << "/" << f << " differs";
  }
  // Frames, when the case renders them: the same names (numbered by step) and bytes.
  if (fs::exists(a + "/frames") || fs::exists(b + "/frames")) {
    std::set<std::string> fa, fb;
    for (const auto& e : fs::directory_iterator(a + "/frames")) fa.insert(e.path().filename().string());
    for (const auto& e : fs::directory_iterator(b + "/frames")) fb.insert(e.path().filename().string());
    EXPECT_EQ(fa, fb) << label << ": frames";
    for (const auto& f : fa)
      EXPECT_TRUE(slurp(a + "/frames/" + f) == slurp(b + "/frames/" + f)) << label << ": frames/" << f << " differs";
  }
}

/// Runs `case_file` uninterrupted into `<tag>_full`, then once per kill: stopped at the step,
/// checked to have stopped where aimed, resumed, outputs compared.
void kill_and_resume(const std::string& case_file, const std::string& tag, const std::string& device,
                     const std::vector<Kill>& kills) {
  const std::string full = fresh_dir(tag + "_full");
  const auto r = run_command(run_cmd(case_file, full, device));
  ASSERT_EQ(r.status, 0) << r.output;
  const std::string full_log = slurp(full + "/run.log");
  const auto fin = full_log.find("finished: ");
  ASSERT_NE(fin, std::string::npos) << full_log;
  const std::uint64_t last_step = std::stoull(full_log.substr(fin + 10));
  for (auto k : kills) {
    if (k.step == 0) k.step = last_step;
    ASSERT_LE(k.step, last_step);
    const std::string label = tag + " " + (k.abort ? "abort" : "SIGTERM") + " at step " + std::to_string(k.step);
    const std::string d = fresh_dir(tag + "_" + std::to_string(k.step));
    const std::string hook = k.abort ? "BIODEM_TEST_ABORT_AT_STEP=" : "BIODEM_TEST_SIGNAL_AT_STEP=";
    const auto rk = run_command(hook + std::to_string(k.step) + " " + run_cmd(case_file, d, device));
    ASSERT_EQ(rk.status, k.abort ? 137 : 143) << label << "\n" << rk.output;
    const std::string log = slurp(d + "/run.log");
    ASSERT_EQ(where_stopped(log), k.where) << label << "\n" << log;
    if (k.where == "insert") {
      // Stopped between two waves: fewer waves logged than the whole insertion takes.
      EXPECT_LT(count(log, "insertion wave "), count(full_log, "insertion wave ")) << label;
      if (!k.abort) {
        EXPECT_NE(rk.output.find("while inserting particles"), std::string::npos) << rk.output;
      }
    }
    if (!k.abort) {
      EXPECT_NE(rk.output.find("continue with --resume"), std::string::npos) << rk.output;
    }
    ASSERT_TRUE(fs::exists(d + "/checkpoint.bin")) << label;
    const auto rr = run_command(run_cmd(case_file, d, device) + " --resume");
    ASSERT_EQ(rr.status, 0) << label << "\n" << rr.output;
    if (k.where == "insert") {
      EXPECT_NE(slurp(d + "/run.log").find("insertion resumes at t = "), std::string::npos) << label;
    }
    expect_same_outputs(full, d, label);
  }
}

}  // namespace

// 1000 beads in four waves 600 steps apart (waves at steps 0, 600, 1200 and 1800: 893, 16, 58
// and 33 beads); checkpoints every 200 steps, samples every 133. Killed in the first fall between
// checkpoints (SIGTERM 450), right after a checkpoint that closes a fall (abort 601: resumes at
// 600, before wave 2), in the third fall (abort 1500: resumes at 1400), on the last step of a
// fall (SIGTERM 1200) and on the last step before the final wave (SIGTERM 1800: the sample right
// after insertion is off the sampling cadence).
TEST(ResumeInsertion, DrumKilledDuringInsertionResumesBitForBit) {
  kill_and_resume(kWaves, "ins_cpu", "cpu",
                  {{false, 450, "insert"}, {true, 601, "insert"}, {true, 1500, "insert"}, {false, 1200, "insert"},
                   {false, 1800, "insert"}});
}

// The waves on the output cadence: samples every 200 steps and snapshots every 600, so that each
// wave (steps 600, 1200, 1800) is made at the time of a fall's last step that is due a sample and
// a snapshot. That step's outputs wait for the wave: one row and one snapshot per time, of the
// state with the wave's beads (before, the step's outputs showed the state before the wave, and
// the end of insertion wrote a second snapshot of the same time, 1000 beads against 967). Killed
// and resumed on those steps, bit for bit (frames too: before, a resume from the checkpoint of
// a fall's last step numbered every later frame one too high).
TEST(ResumeInsertion, WavesOnTheOutputCadenceGiveOneStatePerTime) {
#if BIODEM_HAVE_OPENCV
  const std::string frames = "\nframe_every_s = 0.009\nframe_size_px = 64";
#else
  const std::string frames;  // (the lean build renders no frames)
#endif
  const std::string case_file = edited_case(
      kWaves, {{"sample_hz = 500.0", "sample_hz = 333.3333333333"}, {"snapshot_every_s = 0.005", "snapshot_every_s = 0.009" + frames}},
      "ins_cadence.toml");
  const std::string d = fresh_dir("ins_cadence_once");
  const auto r = run_command(run_cmd(case_file, d, "cpu"));
  ASSERT_EQ(r.status, 0) << r.output;
  ASSERT_NE(slurp(d + "/run.log").find("sampling: every 200 steps"), std::string::npos);
  // Times strictly increasing in the series and in each collection.
  const auto series = read_csv(d + "/series.csv");
  const auto t = to_numbers(series.at("time_s"));
  for (std::size_t i = 1; i < t.size(); ++i) EXPECT_LT(t[i - 1], t[i]) << "series row " << i;
  for (const char* pvd : {"/snapshots.pvd", "/bodies.pvd"}) {
    const std::string x = slurp(d + pvd);
    std::vector<double> ts;
    for (auto at = x.find("timestep=\""); at != std::string::npos; at = x.find("timestep=\"", at + 1))
      ts.push_back(std::stod(x.substr(at + 10)));
    ASSERT_GE(ts.size(), 4u) << pvd;
    for (std::size_t i = 1; i < ts.size(); ++i) EXPECT_LT(ts[i - 1], ts[i]) << pvd << " entry " << i;
  }
  // The trace at the last wave's time (step 1800, t = 0.027 s) holds every bead.
  std::size_t at_last_wave = 0;
  std::istringstream trace(slurp(d + "/trace.csv"));
  std::string line;
  while (std::getline(trace, line))
    if (line.rfind("0.027,", 0) == 0) ++at_last_wave;
  EXPECT_EQ(at_last_wave, 1000u);
  // Frames numbered by step: frame k after step 600 (k + 1), the waves' steps included.
  if (!frames.empty()) {
    for (const char* f : {"000000.png", "000001.png", "000002.png", "000003.png"}) {
      EXPECT_TRUE(fs::exists(d + "/frames/" + f)) << f;
    }
  }
  kill_and_resume(case_file, "ins_cadence", "cpu", {{false, 1200, "insert"}, {true, 1801, "settle"}, {false, 1800, "insert"}});
}

// The GPU engine's kernels on CPU threads: the device state is uploaded again after a resume
// inside the insertion.
TEST(ResumeInsertion, GpuEngineKilledDuringInsertionResumesBitForBit) {
  kill_and_resume(kWaves, "ins_gpuemu", "gpu-emulated", {{true, 1500, "insert"}, {false, 1800, "insert"}});
}

// [heap] with 300 beads: three waves (steps 0, 800 and 1600), fill until at rest (to step
// ~6000), lift (8000 steps), rest. Killed while pouring (abort 700, resumes at 400), while the poured beads
// settle (SIGTERM 3000), while the cylinder is lifted (abort 9000, resumes at 8800) and while
// the heap comes to rest (abort 16000), and on the last step (SIGTERM: the final sample is off
// the sampling cadence; before checkpoint version 5 the resumed run lost it). A --resume of the
// finished run changes nothing (before version 5 it rewrote responses.csv with at_rest = 0).
TEST(ResumeBulkTest, HeapKilledWhilePouringAndLiftingResumesBitForBit) {
  kill_and_resume(kHeap, "heap_resume", "cpu",
                  {{true, 700, "insert"}, {false, 3000, "fill"}, {true, 9000, "lift"}, {true, 16000, "rest"},
                   {false, 0, "rest"}});
  const std::string d = (fs::current_path() / "out_heap_resume_16000").string();  // fresh_dir() would empty it
  const std::string responses = slurp(d + "/responses.csv"), series = slurp(d + "/series.csv");
  ASSERT_NE(responses.find("at_rest,1,"), std::string::npos) << responses;
  const auto rr = run_command(run_cmd(kHeap, d, "cpu") + " --resume");
  ASSERT_EQ(rr.status, 0) << rr.output;
  EXPECT_EQ(slurp(d + "/responses.csv"), responses);
  EXPECT_EQ(slurp(d + "/series.csv"), series);
}

// [bulk_density] (tests/cases/bulk_density_tiny.toml, 1200 beads in three waves at steps 0, 3612
// and 7224, filled until at rest near step 23400, then struck off): killed while pouring (abort
// 5000, resumes at 4800), while filling (SIGTERM 12000) and on the last step, before the surplus
// is struck off and responses.csv is written (SIGTERM).
TEST(ResumeBulkTest, BulkDensityKilledWhilePouringAndFillingResumesBitForBit) {
  const std::string c = with_resume_outputs("bulk_density_tiny.toml", "bulk_density_resume");
  ASSERT_FALSE(c.empty());
  kill_and_resume(c, "bd_resume", "cpu", {{true, 5000, "insert"}, {false, 12000, "fill"}, {false, 0, "fill"}});
}

// [shear_box] (tests/cases/shear_box_tiny.toml, 700 beads in two waves at steps 0 and 3362,
// filled to step ~8100, gate lifted for 8000 steps, flow at rest near step 33600): killed while
// pouring (abort 2000), while filling (SIGTERM 6000), while the gate is lifted and beads flow into
// the sink (abort 12000, resumes at 11600) and while the flow comes to rest (abort 25000).
TEST(ResumeBulkTest, ShearBoxKilledWhilePouringAndGateLiftResumesBitForBit) {
  const std::string c = with_resume_outputs("shear_box_tiny.toml", "shear_box_resume");
  ASSERT_FALSE(c.empty());
  kill_and_resume(c, "sb_resume", "cpu",
                  {{true, 2000, "insert"}, {false, 6000, "fill"}, {true, 12000, "gate"}, {true, 25000, "rest"}});
}

// The same shear box on the GPU engine (its kernels on CPU threads): the gate is a translating
// wall moved by the device clock, and the sinks are tested at the steps whose number is a
// multiple of 10, so a resumed run removes the same beads at the same steps: killed while the
// gate rises and beads flow into the sink (abort 12000) and while the flow comes to rest (abort
// 25000), it resumes bit for bit.
TEST(ResumeBulkTest, ShearBoxOnTheGpuEngineKilledDuringGateLiftResumesBitForBit) {
  const std::string c = with_resume_outputs("shear_box_tiny.toml", "shear_box_resume_gpu");
  ASSERT_FALSE(c.empty());
  kill_and_resume(c, "sb_resume_gpu", "gpu-emulated", {{true, 12000, "gate"}, {true, 25000, "rest"}});
}
