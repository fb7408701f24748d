// `biodem calibrate` (issue 9): the result depends only on the CALIB file and its seed, not on
// --jobs or MPI, and a killed campaign resumed with --resume ends exactly like an uninterrupted one.
// Micro campaign (tests/cases/calib_micro): 8 x (1 + 1 generation) evaluations of a 120-bead heap
// and a 100-bead shear box, ~20-40 s per campaign. Rows are compared without wall_s (a timing).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <utility>

#include "calib/calib_file.hpp"
#include "test_util.hpp"

using namespace biodem::testing;
namespace fs = std::filesystem;

namespace {

const std::string kCalib = source_dir() + "/tests/cases/calib_micro/campaign.toml";

/// The file without its last column (wall_s).
std::string without_wall(const std::string& path) {
  std::ifstream in(path);
  std::string line, out;
  while (std::getline(in, line)) out += line.substr(0, line.rfind(',')) + "\n";
  return out;
}

std::size_t lines(const std::string& path) {
  std::ifstream in(path);
  std::size_t n = 0;
  std::string l;
  while (std::getline(in, l)) ++n;
  return n;
}

std::string campaign(const std::string& tag, int jobs) {
  const std::string d = fresh_dir("calib_" + tag);
  const auto r = run_command(biodem_exe() + " calibrate " + kCalib + " --out " + d + " --jobs " + std::to_string(jobs));
  EXPECT_EQ(r.status, 0) << r.output;
  return d;
}

}  // namespace

TEST(Calibrate, JobsAndResumeDoNotChangeTheResult) {
  const std::string a = campaign("jobs1", 1), b = campaign("jobs2", 2);
  ASSERT_EQ(lines(a + "/evaluations.csv"), 17u);  // header + 8 x 2 batches
  EXPECT_EQ(without_wall(a + "/evaluations.csv"), without_wall(b + "/evaluations.csv"));
  EXPECT_EQ(without_wall(a + "/pareto.csv"), without_wall(b + "/pareto.csv"));
  EXPECT_GE(lines(a + "/pareto.csv"), 2u);
  EXPECT_TRUE(fs::exists(a + "/pareto.png"));
  EXPECT_TRUE(fs::exists(a + "/pareto.svg"));
  EXPECT_TRUE(fs::exists(a + "/retainment_ratio_vs_ced_j_m3.png"));
  // The micro heap is filled well below the procedure's two diameters (to be quick): each test
  // run's warning reaches campaign.log, with the heaps that were not found.
  const std::string alog = slurp(a + "/campaign.log");
  EXPECT_NE(alog.find("heap: WARNING: the fill stands "), std::string::npos) << alog;
  EXPECT_NE(alog.find(" warnings of test runs and "), std::string::npos) << alog;

  // Kill a campaign (and its child runs) in the middle of its second batch, once two test runs
  // of that batch have finished, then resume it: the first batch comes from cache.csv, the
  // finished runs of the second are re-used, the rest is run.
  const std::string c = fresh_dir("calib_killed");
  const std::string script = "setsid " + biodem_exe() + " calibrate " + kCalib + " --out " + c +
                             " --jobs 2 >/dev/null 2>&1 & pid=$!; "
                             "for i in $(seq 1 2400); do n=$(cat " + c + "/runs/g1/*/*/out/run.log 2>/dev/null | "
                             "grep -c ^finished:); [ \"$n\" -ge 2 ] && break; sleep 0.05; done; kill -9 -$pid; "
                             "wait $pid; true";
  run_command("bash -c '" + script + "'");
  const std::size_t cached = lines(c + "/cache.csv") - 1;
  std::printf("[measured] killed after %zu finished evaluations\n", cached);
  ASSERT_EQ(cached, 8u);
  ASSERT_FALSE(fs::exists(c + "/pareto.csv")) << "the campaign finished before it could be killed";
  const auto r = run_command(biodem_exe() + " calibrate " + kCalib + " --out " + c + " --jobs 2 --resume");
  ASSERT_EQ(r.status, 0) << r.output;
  std::ifstream log(c + "/campaign.log");
  const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find(std::to_string(cached) + " evaluations cached"), std::string::npos) << text;
  EXPECT_EQ(without_wall(a + "/evaluations.csv"), without_wall(c + "/evaluations.csv"));
  EXPECT_EQ(without_wall(a + "/pareto.csv"), without_wall(c + "/pareto.csv"));

#ifdef BIODEM_HAVE_MPI
  // The same campaign over 3 MPI ranks on localhost (rank 0 runs NSGA-II, ranks 1-2 the tests).
  const std::string m = fresh_dir("calib_mpi");
  const auto rm = run_command("mpirun --oversubscribe --allow-run-as-root -np 3 " + biodem_exe() + " calibrate " +
                              kCalib + " --out " + m);
  ASSERT_EQ(rm.status, 0) << rm.output;
  EXPECT_NE(slurp(m + "/campaign.log").find("heap: WARNING: the fill stands "), std::string::npos)
      << "the ranks pass the runs' warnings on";
  EXPECT_NE(slurp(m + "/campaign.log").find(", MPI ranks 3 (2 running tests);"), std::string::npos)
      << slurp(m + "/campaign.log");
  EXPECT_NE(text.find(", jobs 2;"), std::string::npos) << text;
  EXPECT_EQ(without_wall(a + "/evaluations.csv"), without_wall(m + "/evaluations.csv"));
  EXPECT_EQ(without_wall(a + "/pareto.csv"), without_wall(m + "/pareto.csv"));
#endif
}

// Ctrl-C (SIGINT to the process group) and SIGTERM to the campaign alone, in the middle of its
// second batch: the campaign stops with 130 / 143 and a line saying so, scores nothing of that
// batch (before: the test runs stopped by the signal were scored as failed, o1 = o2 = 1e9, and
// the campaign went on to exit 0 with another Pareto set), and --resume ends exactly like an
// uninterrupted campaign.
TEST(Calibrate, SignalsStopTheCampaignAndResumeGivesTheSameResult) {
  const std::string a = campaign("signal_ref", 2);
  for (const std::string sig : {"INT", "TERM"}) {
    const std::string c = fresh_dir("calib_sig" + sig);
    const std::string target = sig == "INT" ? "-$pid" : "$pid";  // the group, as a terminal; or the campaign
    const std::string script = "setsid " + biodem_exe() + " calibrate " + kCalib + " --out " + c +
                               " --jobs 2 >" + c + ".stdout 2>&1 & pid=$!; "
                               "for i in $(seq 1 2400); do n=$(cat " + c + "/runs/g1/*/*/out/run.log 2>/dev/null | "
                               "grep -c ^finished:); [ \"$n\" -ge 1 ] && break; sleep 0.02; done; kill -" + sig + " " +
                               target + " && echo sent; wait $pid; echo status=$?";
    const auto k = run_command("bash -c '" + script + "'");
    if (k.output.find("sent") == std::string::npos) GTEST_SKIP() << "the campaign finished before the signal";
    EXPECT_FALSE(fs::exists(c + "/pareto.csv")) << "the campaign went on after the signal";
    EXPECT_NE(k.output.find(sig == "INT" ? "status=130" : "status=143"), std::string::npos) << k.output;
    const std::string said = slurp(c + ".stdout");
    EXPECT_NE(said.find("calibrate: stopped by SIG" + sig + " in generation 1"), std::string::npos) << said;
    EXPECT_NE(said.find("continue with --resume"), std::string::npos) << said;
    EXPECT_NE(slurp(c + "/campaign.log").find("stopped by SIG" + sig), std::string::npos);
    EXPECT_EQ(lines(c + "/cache.csv") - 1, 8u) << "only the first batch is scored";
    EXPECT_EQ(slurp(c + "/campaign.log").find("1e9"), std::string::npos) << "no test run scored as failed";
    const auto r = run_command(biodem_exe() + " calibrate " + kCalib + " --out " + c + " --jobs 2 --resume");
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_EQ(without_wall(a + "/evaluations.csv"), without_wall(c + "/evaluations.csv")) << sig;
    EXPECT_EQ(without_wall(a + "/pareto.csv"), without_wall(c + "/pareto.csv")) << sig;
  }
}

// Bad CALIB files: one line naming the key, non-zero exit, before any run (no runs/ folder).
TEST(Calibrate, BadInputIsAOneLineErrorNamingTheKey) {
  std::ifstream in(kCalib);
  const std::string good((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string d = fresh_dir("calib_bad");
  fs::create_directories(d);
  for (const char* f : {"base.toml", "heap.toml", "shear_box.toml"})
    fs::copy_file(source_dir() + "/tests/cases/calib_micro/" + f, d + "/" + f);
  const std::vector<std::tuple<std::string, std::string, std::string>> cases = {
      {"pair.bead.bead.sliding_friction", "pair.bead.bead.slding_friction", "unknown parameter path"},
      {"pair.bead.steel.rolling_friction", "pair.bead.glass.rolling_friction", "no [[pair]] of materials bead and glass"},
      {"lower = 0.1\nupper = 0.9\nkeys = [\"pair.bead.bead.sliding", "lower = -0.1\nupper = 0.9\nkeys = [\"pair.bead.bead.sliding",
       "[[parameter]] #1.lower"},
      {"lower = 0.0\nupper = 80000.0", "lower = -5.0\nupper = 80000.0", "[[parameter]] #3.lower"},
      {"population = 8", "population = 6", "[campaign].population = 6"},
      {"population = 8", "population = 8.5", "[campaign].population = 8.5: must be a non-negative integer"},
      {"response = \"retainment_ratio\"\nvalue = 0.7\nunit = \"-\"", "response = \"heap_height_m\"\nvalue = 0.7\nunit = \"m\"",
       "missing target for response \"retainment_ratio\""},
      {"unit = \"deg\"", "unit = \"rad\"", "[[target]] #1.unit = \"rad\": angle_of_repose_deg is measured in \"deg\""},
  };
  for (const auto& [from, to, expect] : cases) {
    std::string text = good;
    const auto at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    const std::string f = d + "/bad.toml";  // next to copies of its cases
    { std::ofstream(f) << text; }
    const auto r = run_command(biodem_exe() + " calibrate " + f + " --out " + d + "/out");
    EXPECT_NE(r.status, 0) << to;
    EXPECT_NE(r.output.find(expect), std::string::npos) << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
    EXPECT_FALSE(fs::exists(d + "/out/runs")) << to;
  }
}

// `biodem check` on a calibration file checks it as calibrate does (exit 0, its tests, parameters
// and targets printed); on a test's case or base file alone it checks the calibration files beside
// it that use it (so that every shipped .toml passes `check`), and without one says to check the
// calibration file (before: "[campaign]: unknown top-level key" and "[run]: required table is
// missing" with nothing more).
TEST(Calibrate, CheckTakesACalibrationFileAndPointsAFragmentToIt) {
  const std::string dir = source_dir() + "/cases/calibration/";
  for (const char* f : {"quick/campaign.toml", "quick/twin_campaign.toml", "quick/drum_narrow.toml", "twin_campaign_raw.toml"}) {
    const auto r = run_command(biodem_exe() + " check " + dir + f);
    EXPECT_EQ(r.status, 0) << f << ": " << r.output;
    EXPECT_NE(r.output.find("calibration file: "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("parameters:\n"), std::string::npos) << r.output;
  }
  const auto twin = run_command(biodem_exe() + " check " + dir + "quick/twin_campaign.toml");
  EXPECT_NE(twin.output.find("  mu_s in [0.1, 0.9]: pair.bead.bead.sliding_friction"), std::string::npos) << twin.output;
  for (const char* f : {"quick/heap.toml", "quick/base.toml", "base_raw.toml"}) {
    const auto r = run_command(biodem_exe() + " check " + dir + f);
    EXPECT_EQ(r.status, 0) << f << ": " << r.output;
    EXPECT_NE(r.output.find(std::string(f) + ": not a case by itself, but a file of test"), std::string::npos)
        << f << ": " << r.output;
    EXPECT_NE(r.output.find("calibration file: "), std::string::npos) << r.output;
  }
  const auto base = run_command(biodem_exe() + " check " + dir + "base_raw.toml");
  EXPECT_NE(base.output.find("a file of tests 'heap', 'bulk_density', 'shear_box' of the calibration " + dir +
                             "twin_campaign_raw.toml"),
            std::string::npos)
      << base.output;
  // A fragment without a calibration file beside it: one line pointing to it.
  const std::string d = fresh_dir("check_fragment_alone");
  fs::create_directories(d);
  fs::copy_file(dir + "quick/heap.toml", d + "/heap.toml");
  const auto r = run_command(biodem_exe() + " check " + d + "/heap.toml");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("checked through its calibration file: biodem check CALIB.toml"), std::string::npos)
      << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  // A calibration file beside it that is broken: its error, status 2.
  std::ofstream(d + "/campaign.toml") << "[campaign]\npopulation = 8\n[[test]]\nname = \"heap\"\ncase = \"heap.toml\"\n"
                                         "[[parameter]]\nname = \"x\"\n";
  const auto broken = run_command(biodem_exe() + " check " + d + "/heap.toml");
  EXPECT_EQ(broken.status, 2) << broken.output;
  EXPECT_NE(broken.output.find("campaign.toml"), std::string::npos) << broken.output;
}

// Every shipped campaign file loads: its tests, bases, targets and parameter keys resolve, and
// each test's case (base merged in) is valid with the parameters at both ends of their bounds
// (load_calib checks all of this before a campaign runs anything).
TEST(Calibrate, ShippedCampaignFilesAreValid) {
  const std::string dir = source_dir() + "/cases/calibration/";
  for (const char* f : {"quick/campaign.toml", "quick/twin_campaign.toml", "twin_campaign_raw.toml"}) {
    try {
      const biodem::calib::CalibConfig c = biodem::calib::load_calib(dir + f);
      EXPECT_EQ(c.tests.size(), 3u) << f;
      EXPECT_EQ(c.targets.size(), 3u) << f;
      EXPECT_GE(c.parameters.size(), 3u) << f;
    } catch (const std::exception& e) {
      ADD_FAILURE() << f << ": " << e.what();
    }
  }
  try {  // the drum test that narrows the quick twin's Pareto set
    const biodem::calib::CalibConfig c = biodem::calib::load_calib(dir + "quick/drum_narrow.toml");
    ASSERT_EQ(c.tests.size(), 1u);
    EXPECT_TRUE(c.tests[0].drum.has_value());
    EXPECT_EQ(c.targets.size(), 2u);
    EXPECT_EQ(c.parameters.size(), 3u);
  } catch (const std::exception& e) {
    ADD_FAILURE() << "quick/drum_narrow.toml: " << e.what();
  }
}

// Narrowing a Pareto set with the drum (SPEC 7; docs/calibration.md "Drum tests"): `calibrate
// --evaluate FILE` runs the drum test for each row of FILE (here two points of a bulk-test
// Pareto set) and scores them from the drum's descriptors; --resume runs nothing again; a bad
// FILE is a one-line error before any run. Two quick drums of ~2.6 s each.
TEST(Calibrate, DrumTestEvaluatesTheRowsOfAParetoFile) {
  const std::string d = fresh_dir("calib_drum_narrow");
  fs::create_directories(d);
  const std::string calib = source_dir() + "/cases/calibration/quick/drum_narrow.toml";
  {
    std::ofstream(d + "/pareto.csv") << "generation,index,mu_s,mu_r,ced_j_m3,angle_of_repose_deg,o1,o2,wall_s\n"
                                        "4,8,0.777,0.319,11547.8,14.9,0.014,0.011,0.88\n"
                                        "4,4,0.900,0.827,9303.5,15.4,0.033,0,0.80\n";
  }
  const std::string out = d + "/narrow";
  const auto r = run_command(biodem_exe() + " calibrate " + calib + " --out " + out + " --jobs 2 --evaluate " + d + "/pareto.csv");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto ev = read_csv(out + "/evaluations.csv");
  ASSERT_EQ(ev.at("index").size(), 2u);
  // The shortest text that reads back as the same double: 0.777 in, 0.777 out.
  EXPECT_EQ(ev.at("mu_s")[0], "0.777");
  EXPECT_EQ(ev.at("mu_r")[1], "0.827");
  // o1 and o2: the relative errors of the drum's median UAS and median r2 to the file's targets.
  for (std::size_t k = 0; k < 2; ++k) {
    const double uas = std::stod(ev.at("uas_deg_p50")[k]), r2 = std::stod(ev.at("surface_r2_p50")[k]);
    EXPECT_GT(uas, 95.0) << k;  // a bed that turned with the drum before its avalanches
    EXPECT_LT(uas, 200.0) << k;
    EXPECT_GT(r2, 0.0) << k;
    EXPECT_LE(r2, 1.0) << k;
    EXPECT_NEAR(std::stod(ev.at("o1")[k]), std::abs(uas - 154.922657) / 154.922657, 1e-12) << k;
    EXPECT_NEAR(std::stod(ev.at("o2")[k]), std::abs(r2 - 0.9018358713) / 0.9018358713, 1e-12) << k;
    const std::string run = out + "/runs/evaluate/e" + std::to_string(k) + "/drum/out/";
    for (const char* f : {"series.csv", "events.csv", "descriptors.csv", "responses.csv"})
      EXPECT_TRUE(fs::exists(run + f)) << run + f;
    const auto resp = read_csv(run + "responses.csv");
    const auto& names = resp.at("response");
    const auto at = std::find(names.begin(), names.end(), "uas_deg_p50");
    ASSERT_NE(at, names.end());
    EXPECT_NEAR(std::stod(resp.at("value")[static_cast<std::size_t>(at - names.begin())]), uas, 1e-9 * uas);
  }
  // The responses are `biodem analyze`'s: its descriptors.csv of the same series, byte for byte.
  const std::string copy = d + "/analyze_copy";
  fs::create_directories(copy);
  fs::copy_file(out + "/runs/evaluate/e0/drum/out/series.csv", copy + "/series.csv");
  const auto an = run_command(biodem_exe() + " analyze " + copy + " --no-plots");
  ASSERT_EQ(an.status, 0) << an.output;
  EXPECT_EQ(slurp(copy + "/descriptors.csv"), slurp(out + "/runs/evaluate/e0/drum/out/descriptors.csv"));
  EXPECT_EQ(slurp(copy + "/events.csv"), slurp(out + "/runs/evaluate/e0/drum/out/events.csv"));
  // pareto.csv: rows of evaluations.csv, at least one.
  const std::string evals = slurp(out + "/evaluations.csv");
  std::ifstream pin(out + "/pareto.csv");
  std::string prow;
  std::getline(pin, prow);
  std::size_t pareto_rows = 0;
  while (std::getline(pin, prow)) {
    ++pareto_rows;
    EXPECT_NE(evals.find(prow), std::string::npos) << prow;
  }
  EXPECT_GE(pareto_rows, 1u);
  EXPECT_TRUE(fs::exists(out + "/pareto.png"));
  EXPECT_NE(slurp(out + "/campaign.log").find("evaluating the 2 parameter vectors of"), std::string::npos);

  // --resume of the finished folder: both from the cache, the same file.
  const std::string before = without_wall(out + "/evaluations.csv");
  const auto again = run_command(biodem_exe() + " calibrate " + calib + " --out " + out + " --resume --evaluate " + d + "/pareto.csv");
  ASSERT_EQ(again.status, 0) << again.output;
  EXPECT_NE(slurp(out + "/campaign.log").find("evaluated 2 vectors (0 run now)"), std::string::npos);
  EXPECT_EQ(without_wall(out + "/evaluations.csv"), before);

  // --resume across modes is refused: a search into this --evaluate folder, and --evaluate into a
  // search folder (they would take each other's cached evaluations and overwrite the results).
  const auto mixed = run_command(biodem_exe() + " calibrate " + calib + " --out " + out + " --resume");
  EXPECT_NE(mixed.status, 0);
  EXPECT_NE(mixed.output.find("holds an --evaluate campaign; a search needs another folder"), std::string::npos) << mixed.output;
  EXPECT_EQ(without_wall(out + "/evaluations.csv"), before);

  // A row outside the CALIB file's bounds: one line naming the file, line and column; nothing runs.
  { std::ofstream(d + "/bad.csv") << "mu_s,mu_r,ced_j_m3\n0.5,0.5,1000\n0.5,0.5,90000\n"; }
  const auto bad = run_command(biodem_exe() + " calibrate " + calib + " --out " + d + "/bad --evaluate " + d + "/bad.csv");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.output.find("bad.csv line 3, column ced_j_m3 = 90000: outside the parameter's bounds"), std::string::npos)
      << bad.output;
  EXPECT_EQ(std::count(bad.output.begin(), bad.output.end(), '\n'), 1) << bad.output;
  EXPECT_FALSE(fs::exists(d + "/bad/runs"));
}

// [[test]] seeds with the real runs: the micro heap at one parameter vector, seeds 1 and 2, each
// run in its own folder with its seed in its case, and the evaluation's angle the mean of the two
// runs' responses.csv values.
TEST(Calibrate, SeedsAverageTheRunsOfATest) {
  const std::string d = fresh_dir("calib_seeds");
  fs::create_directories(d);
  const std::string micro = source_dir() + "/tests/cases/calib_micro/";
  std::string calib = slurp(micro + "campaign.toml");
  const std::string heap = "name = \"heap\"\ncase = \"heap.toml\"\nbase = \"base.toml\"\n";
  ASSERT_NE(calib.find(heap), std::string::npos);
  calib.replace(calib.find(heap), heap.size(),
                "name = \"heap\"\ncase = \"" + micro + "heap.toml\"\nbase = \"" + micro + "base.toml\"\nseeds = [1, 2]\n");
  const std::string box = "case = \"shear_box.toml\"\nbase = \"base.toml\"";
  ASSERT_NE(calib.find(box), std::string::npos);
  calib.replace(calib.find(box), box.size(), "case = \"" + micro + "shear_box.toml\"\nbase = \"" + micro + "base.toml\"");
  std::ofstream(d + "/campaign.toml") << calib;
  std::ofstream(d + "/point.csv") << "mu_s,mu_r,ced_j_m3\n0.7,0.5,40000\n";
  const auto r = run_command(biodem_exe() + " calibrate " + d + "/campaign.toml --out " + d + "/out --jobs 2 --evaluate " +
                             d + "/point.csv");
  ASSERT_EQ(r.status, 0) << r.output;
  double sum = 0.0;
  for (const int seed : {1, 2}) {
    const std::string run = d + "/out/runs/evaluate/e0/heap/seed" + std::to_string(seed);
    EXPECT_NE(slurp(run + "/case.toml").find("\nseed = " + std::to_string(seed) + "\n"), std::string::npos);
    const auto resp = read_csv(run + "/out/responses.csv");
    const auto& names = resp.at("response");
    const auto at = std::find(names.begin(), names.end(), "angle_of_repose_deg");
    ASSERT_NE(at, names.end());
    sum += std::stod(resp.at("value")[static_cast<std::size_t>(at - names.begin())]);
  }
  EXPECT_FALSE(fs::exists(d + "/out/runs/evaluate/e0/heap/case.toml"));  // only the seeds' runs
  EXPECT_TRUE(fs::exists(d + "/out/runs/evaluate/e0/shear_box/out/responses.csv"));
  const auto ev = read_csv(d + "/out/evaluations.csv");
  ASSERT_EQ(ev.at("angle_of_repose_deg").size(), 1u);
  EXPECT_NEAR(std::stod(ev.at("angle_of_repose_deg")[0]), sum / 2.0, 1e-9 * std::abs(sum)) << sum;
  EXPECT_NE(slurp(d + "/out/campaign.log").find("evaluation g0 e0 heap, seeds 1 2: angle_of_repose_deg "), std::string::npos);
}

// A drum test on the GPU engine: the device comes from the test's case (`[run] device`), every
// run of the campaign goes to it, and runs made at once (--jobs 2) give the evaluations of runs
// made one by one. Here the GPU engine's kernels on CPU threads ("gpu-emulated"; on a GPU
// machine the same file with "gpu"); the quick drum shortened to 0.3 revolution (~5 s a run).
TEST(Calibrate, DrumTestOnTheGpuEngineGivesTheSameEvaluationsWithJobs) {
  const std::string d = fresh_dir("calib_drum_gpu");
  fs::create_directories(d);
  const std::string quick = source_dir() + "/cases/calibration/quick/";
  {
    std::ifstream in(quick + "drum.toml");
    std::string drum((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string rev = "revolutions = 0.8";
    ASSERT_NE(drum.find(rev), std::string::npos);
    drum.replace(drum.find(rev), rev.size(), "revolutions = 0.3");
    std::ofstream(d + "/drum_gpu.toml") << "[run]\ndt_s = 2.5e-5\nseed = 3\ndevice = \"gpu-emulated\"\n\n" << drum;
    std::ifstream cin(quick + "drum_narrow.toml");
    std::string calib((std::istreambuf_iterator<char>(cin)), std::istreambuf_iterator<char>());
    for (const auto& [from, to] : {std::pair<std::string, std::string>{"case = \"drum.toml\"", "case = \"drum_gpu.toml\""},
                                   {"base = \"base.toml\"", "base = \"" + quick + "base.toml\""}}) {
      ASSERT_NE(calib.find(from), std::string::npos) << from;
      calib.replace(calib.find(from), from.size(), to);
    }
    std::ofstream(d + "/narrow_gpu.toml") << calib;
    std::ofstream(d + "/points.csv") << "mu_s,mu_r,ced_j_m3\n0.777,0.319,11547.8\n0.900,0.827,9303.5\n";
  }
  for (const int jobs : {1, 2}) {
    const auto r = run_command(biodem_exe() + " calibrate " + d + "/narrow_gpu.toml --out " + d + "/j" +
                               std::to_string(jobs) + " --jobs " + std::to_string(jobs) + " --evaluate " + d + "/points.csv");
    ASSERT_EQ(r.status, 0) << r.output;
  }
  for (const char* e : {"e0", "e1"}) {
    const std::string log = slurp(d + "/j2/runs/evaluate/" + e + "/drum/out/run.log");
    EXPECT_NE(log.find("engine: GPU engine on CPU threads"), std::string::npos) << log;
  }
  const auto ev = read_csv(d + "/j2/evaluations.csv");
  ASSERT_EQ(ev.at("uas_deg_p50").size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) EXPECT_GT(std::stod(ev.at("uas_deg_p50")[k]), 90.0) << k;
  EXPECT_EQ(without_wall(d + "/j1/evaluations.csv"), without_wall(d + "/j2/evaluations.csv"));
  EXPECT_EQ(without_wall(d + "/j1/pareto.csv"), without_wall(d + "/j2/pareto.csv"));
}
