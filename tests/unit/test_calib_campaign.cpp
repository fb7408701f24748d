// The campaign library (src/calib) without the command line and without simulations: the
// evaluation files read back bit for bit, the objectives, the job order of the scheduler, and a
// whole campaign over a model of the bulk tests (a TestRunner that computes the responses from
// the parameters): its files do not depend on --jobs, --resume re-uses the cache, and a folder
// with an earlier campaign is refused.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>
#include <vector>

#include "calib/calib_file.hpp"
#include "calib/evaluations_csv.hpp"
#include "calib/objectives.hpp"
#include "calib/scheduler.hpp"
#ifdef BIODEM_HAVE_PAGMO
#include "calib/campaign.hpp"
#endif
#include "core/error.hpp"
#include "output/output_dir.hpp"
#include "test_util.hpp"

#include <toml++/toml.h>

using namespace biodem;
using namespace biodem::testing;
namespace fs = std::filesystem;

namespace {

// tests/cases/calib_micro: parameters mu_s, mu_r, ced_j_m3; tests heap and shear_box; targets
// angle_of_repose_deg = 25 (o1) and retainment_ratio = 0.7 (o2).
calib::CalibConfig micro() { return calib::load_calib(source_dir() + "/tests/cases/calib_micro/campaign.toml"); }

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

/// A file without its last column (wall_s, a timing).
std::string without_wall(const std::string& path) {
  std::ifstream in(path);
  std::string line, out;
  while (std::getline(in, line)) out += line.substr(0, line.rfind(',')) + "\n";
  return out;
}

}  // namespace

TEST(CalibEvaluationsCsv, RowsReadBackBitForBitAndBrokenLinesAreSkipped) {
  const auto c = micro();
  ASSERT_EQ(c.parameters.size(), 3u);
  ASSERT_EQ(calib::response_names(c), (std::vector<std::string>{"angle_of_repose_deg", "retainment_ratio"}));
  EXPECT_EQ(calib::evaluations_header(c),
            "generation,index,mu_s,mu_r,ced_j_m3,angle_of_repose_deg,retainment_ratio,o1,o2,wall_s");
  calib::Evaluation e;
  e.generation = 3;
  e.index = 7;
  e.x = {0.1, 1.0 / 3.0, 61234.567890123456};
  e.responses = {std::nextafter(25.0, 30.0), 2.0 / 3.0};
  e.o1 = 1e-17;
  e.o2 = 1e9;
  e.wall_s = 12.5;
  const std::string d = fresh_dir("calib_csv");
  fs::create_directories(d);
  {
    std::ofstream f(d + "/e.csv");
    const std::string row = calib::evaluation_row(e);
    f << calib::evaluations_header(c) << "\n" << row << "\n" << row.substr(0, row.size() / 2) << "\n"
      << "x,y\n";  // a row cut by a kill, and a malformed one
  }
  const auto rows = calib::read_evaluations(d + "/e.csv", 3, 2);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].generation, 3u);
  EXPECT_EQ(rows[0].index, 7u);
  for (std::size_t k = 0; k < 3; ++k) EXPECT_TRUE(same_bits(rows[0].x[k], e.x[k])) << k;
  for (std::size_t k = 0; k < 2; ++k) EXPECT_TRUE(same_bits(rows[0].responses[k], e.responses[k])) << k;
  EXPECT_TRUE(same_bits(rows[0].o1, e.o1));
  EXPECT_TRUE(same_bits(rows[0].o2, e.o2));
  EXPECT_TRUE(calib::read_evaluations(d + "/missing.csv", 3, 2).empty());
}

// A parameter's key names a pair by its two materials in either order: the campaign's key
// "pair.bead.steel.*" must reach a case whose [[pair]] lists ["steel", "bead"] (else the
// campaign would run the same case for every parameter vector, without an error). The values
// are checked in the case text apply_parameters writes, read back by the case parser.
TEST(CalibFile, ParameterKeyMatchesAPairListedInEitherOrder) {
  calib::CalibConfig c = micro();
  calib::CalibTest t = c.tests.at(0);
  toml::table in = toml::parse(t.case_text);
  int swapped = 0;
  for (auto& e : *in.get_as<toml::array>("pair")) {
    toml::table& p = *e.as_table();
    const auto& m = *p.get_as<toml::array>("materials");
    if (m[0].value_or(std::string()) == "bead" && m[1].value_or(std::string()) == "steel") {
      p.insert_or_assign("materials", toml::array{"steel", "bead"});
      ++swapped;
    }
  }
  ASSERT_EQ(swapped, 1) << "the micro campaign's case has no bead/steel pair";
  std::ostringstream os;
  os << in;
  t.case_text = os.str();
  const std::string out = calib::apply_parameters(c, t, {0.37, 0.21, 1234.0});
  const toml::table tb = toml::parse(out);
  int seen = 0;
  for (const auto& e : *tb.get_as<toml::array>("pair")) {
    const toml::table& p = *e.as_table();
    const auto& m = *p.get_as<toml::array>("materials");
    if (m[0].value_or(std::string()) != "steel") continue;
    ++seen;
    EXPECT_EQ(p["sliding_friction"].value_or(-1.0), 0.37);
    EXPECT_EQ(p["rolling_friction"].value_or(-1.0), 0.21);
    EXPECT_EQ(p["cohesion_energy_density_j_m3"].value_or(-1.0), 617.0);  // factor 0.5 for steel
  }
  EXPECT_EQ(seen, 1);
}

TEST(CalibObjectives, WeightedMeanOfRelativeErrorsAndMissingResponses) {
  auto c = micro();
  EXPECT_DOUBLE_EQ(calib::objective(c, c.o1, {{"angle_of_repose_deg", 30.0}}), 5.0 / 25.0);
  EXPECT_DOUBLE_EQ(calib::objective(c, c.o2, {{"retainment_ratio", 0.35}}), 0.5);
  // Two responses with weights 3 and 1: (3 x 0.2 + 1 x 0.5) / 4.
  c.o1.responses = {"angle_of_repose_deg", "retainment_ratio"};
  c.o1.weights = {3.0, 1.0};
  EXPECT_DOUBLE_EQ(calib::objective(c, c.o1, {{"angle_of_repose_deg", 20.0}, {"retainment_ratio", 1.05}}),
                   (3.0 * 0.2 + 1.0 * 0.5) / 4.0);
  EXPECT_TRUE(std::isnan(calib::objective(c, c.o1, {{"angle_of_repose_deg", 20.0}})));
}

TEST(CalibScheduler, ThreadsReturnTheResultsInJobOrder) {
  std::vector<calib::TestJob> jobs(23);
  for (std::size_t i = 0; i < jobs.size(); ++i) jobs[i].evaluation = i;
  for (int threads : {1, 4}) {
    std::atomic<int> running{0}, most{0};
    const auto out = calib::run_on_threads(jobs, threads, [&](const calib::TestJob& j) {
      const int now = ++running;
      for (int m = most; now > m && !most.compare_exchange_weak(m, now);) {
      }
      // Later jobs finish first: the order of completion is not the order of the jobs.
      std::this_thread::sleep_for(std::chrono::microseconds(200 * (30 - static_cast<int>(j.evaluation))));
      --running;
      calib::TestRun r;
      r.rc = static_cast<int>(j.evaluation);
      return r;
    });
    ASSERT_EQ(out.size(), jobs.size());
    for (std::size_t i = 0; i < out.size(); ++i) EXPECT_EQ(out[i].rc, static_cast<int>(i)) << threads;
    EXPECT_LE(most.load(), threads);
    if (threads == 1) {
      EXPECT_EQ(most.load(), 1);
    }
  }
}

#ifdef BIODEM_HAVE_PAGMO
namespace {

/// A model of the two bulk tests: smooth functions of the parameters, no simulation.
calib::TestRun model(const calib::TestJob& j, std::atomic<int>* calls) {
  if (calls) ++*calls;
  calib::TestRun r;
  const double mu_s = j.x[0], mu_r = j.x[1], ced = j.x[2];
  if (j.test == 0) r.responses["angle_of_repose_deg"] = 10.0 + 30.0 * mu_s + 10.0 * mu_r;
  else r.responses["retainment_ratio"] = std::min(1.0, 0.3 + ced / 80000.0);
  r.responses["at_rest"] = 1.0;
  return r;
}

calib::CampaignSummary run(const calib::CalibConfig& c, const std::string& dir, int jobs, bool resume,
                           std::atomic<int>* calls = nullptr) {
  calib::CampaignOptions o;
  o.out_dir = dir;
  o.jobs = jobs;
  o.resume = resume;
  o.runner = [calls](const calib::TestJob& j) { return model(j, calls); };
  return calib::run_campaign(c, o);
}

}  // namespace

TEST(CalibCampaign, FilesDoNotDependOnJobsAndResumeReusesTheCache) {
  const auto c = micro();  // population 8, 1 generation: 2 batches of 8
  const std::string a = fresh_dir("calib_model_jobs1"), b = fresh_dir("calib_model_jobs3");
  std::atomic<int> calls{0};
  const auto sa = run(c, a, 1, false, &calls);
  EXPECT_EQ(sa.evaluations, 16u);
  EXPECT_GE(sa.pareto, 1u);
  EXPECT_FALSE(sa.mpi_worker);
  EXPECT_LE(calls.load(), 2 * 16);  // two tests per new decision vector
  run(c, b, 3, false);
  EXPECT_EQ(without_wall(a + "/evaluations.csv"), without_wall(b + "/evaluations.csv"));
  EXPECT_EQ(without_wall(a + "/pareto.csv"), without_wall(b + "/pareto.csv"));
  const auto rows = calib::read_evaluations(a + "/evaluations.csv", 3, 2);
  ASSERT_EQ(rows.size(), 16u);
  for (const auto& e : rows) {
    EXPECT_DOUBLE_EQ(e.responses[0], 10.0 + 30.0 * e.x[0] + 10.0 * e.x[1]);
    EXPECT_DOUBLE_EQ(e.o1, std::abs(e.responses[0] - 25.0) / 25.0);
  }
  EXPECT_TRUE(fs::exists(a + "/pareto.png"));
  EXPECT_TRUE(fs::exists(a + "/angle_of_repose_deg_vs_mu_s.svg"));

  // A campaign killed after its first batch: cache.csv holds 8 rows. --resume evaluates only the
  // second batch and ends with the same files.
  const std::string k = fresh_dir("calib_model_resume");
  fs::create_directories(k);
  {
    std::ifstream in(a + "/cache.csv");
    std::ofstream out(k + "/cache.csv");
    std::string line;
    for (int n = 0; n < 9 && std::getline(in, line); ++n) out << line << "\n";
  }
  std::atomic<int> resumed_calls{0};
  run(c, k, 2, true, &resumed_calls);
  EXPECT_LE(resumed_calls.load(), 2 * 8);
  EXPECT_EQ(without_wall(a + "/evaluations.csv"), without_wall(k + "/evaluations.csv"));
  EXPECT_EQ(without_wall(a + "/pareto.csv"), without_wall(k + "/pareto.csv"));
  EXPECT_NE(slurp(k + "/campaign.log").find("8 evaluations cached"), std::string::npos);

  // Without --resume a folder with a campaign is refused; --resume needs a cache.
  EXPECT_THROW(run(c, a, 1, false), Error);
  EXPECT_THROW(run(c, fresh_dir("calib_model_empty"), 1, true), Error);

  // --resume with another CALIB (a target changed: the cached o1 would be of the old one) or in
  // the other mode (--evaluate into this search folder) is refused, and nothing is overwritten.
  const std::string evals_before = slurp(a + "/evaluations.csv");
  auto changed = c;
  changed.targets[0].value = 30.0;
  try {
    run(changed, a, 1, true);
    ADD_FAILURE() << "a resume with another target was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("holds a campaign of another CALIB file"), std::string::npos) << e.what();
  }
  { std::ofstream(a + "/rows.csv") << "mu_s,mu_r,ced_j_m3\n0.5,0.5,1000\n"; }
  calib::CampaignOptions o;
  o.out_dir = a;
  o.resume = true;
  o.evaluate_csv = a + "/rows.csv";
  o.runner = [](const calib::TestJob& j) { return model(j, nullptr); };
  try {
    calib::run_campaign(c, o);
    ADD_FAILURE() << "--evaluate into a search folder was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("holds a search (NSGA-II) campaign; --evaluate needs another folder"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(slurp(a + "/evaluations.csv"), evals_before);
  // --evaluate in its own folder: the model's responses for the row, generation 0, index 0.
  o.out_dir = fresh_dir("calib_model_evaluate");
  o.resume = false;
  const auto se = calib::run_campaign(c, o);
  EXPECT_EQ(se.evaluations, 1u);
  const auto one = calib::read_evaluations(o.out_dir + "/evaluations.csv", 3, 2);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_DOUBLE_EQ(one[0].responses[0], 10.0 + 30.0 * 0.5 + 10.0 * 0.5);
  EXPECT_EQ(one[0].generation, 0u);
  EXPECT_EQ(one[0].index, 0u);
}

// [[test]] seeds: the heap of each evaluation runs once per seed (its case's [run].seed set, in
// its own folder), and its response is the mean over the seeds; a seed whose run lacks it leaves
// the evaluation without it (scored 1e9); campaign.log gives the values seed by seed; a resume
// with other seeds is refused. The model's heap angle is its usual function plus the run's seed.
TEST(CalibCampaign, SeedsRunATestOncePerSeedAndScoreTheirMean) {
  auto c = micro();
  c.tests[0].seeds = {3, 7};
  const std::string d = fresh_dir("calib_model_seeds");
  std::mutex m;
  std::set<std::string> dirs;
  calib::CampaignOptions o;
  o.out_dir = d;
  o.jobs = 2;
  o.runner = [&](const calib::TestJob& j) {
    {
      std::lock_guard<std::mutex> lock(m);
      const std::string rel = j.dir.substr(j.dir.find("/e") + 1);  // e<index>/<test>[/seed<s>]
      dirs.insert(rel.substr(rel.find('/') + 1));
    }
    calib::TestRun r = model(j, nullptr);
    if (j.test == 0) {
      // (the only "seed" key of a case is [run]'s; toml++ writes it "seed = N")
      const auto at = j.case_text.find("\nseed = ");
      EXPECT_NE(at, std::string::npos) << j.case_text;
      const long seed = at == std::string::npos ? 1000 : std::stol(j.case_text.substr(at + 8));
      r.responses["angle_of_repose_deg"] += static_cast<double>(seed);
      if (j.evaluation == 2 && seed == 7) r.responses.erase("angle_of_repose_deg");  // a run that measured nothing
    }
    return r;
  };
  calib::run_campaign(c, o);
  EXPECT_EQ(dirs, (std::set<std::string>{"heap/seed3", "heap/seed7", "shear_box"}));
  const auto rows = calib::read_evaluations(d + "/evaluations.csv", 3, 2);
  ASSERT_EQ(rows.size(), 16u);
  for (const auto& e : rows) {
    if (e.generation == 0 && e.index == 2) {  // (generation 1 may ask for it again: from the cache)
      EXPECT_TRUE(std::isnan(e.responses[0]));
      EXPECT_EQ(e.o1, 1e9);
      continue;
    }
    if (std::isnan(e.responses[0])) continue;  // that vector again, from the cache
    EXPECT_DOUBLE_EQ(e.responses[0], 10.0 + 30.0 * e.x[0] + 10.0 * e.x[1] + 5.0);  // mean of +3 and +7
    EXPECT_DOUBLE_EQ(e.o1, std::abs(e.responses[0] - 25.0) / 25.0);
  }
  const std::string log = slurp(d + "/campaign.log");
  EXPECT_NE(log.find("evaluation g0 e0 heap, seeds 3 7: angle_of_repose_deg "), std::string::npos) << log;
  EXPECT_NE(log.find(", sd 2.82843)"), std::string::npos) << log;  // sqrt(((3-5)^2 + (7-5)^2) / 1)
  EXPECT_NE(log.find("evaluation g0 e2: no value of angle_of_repose_deg - scored as o1 = o2 = 1e9"), std::string::npos)
      << log;
  // The seeds are part of what the folder was made by: a resume with others is refused.
  auto other = c;
  other.tests[0].seeds = {3, 8};
  o.resume = true;
  try {
    calib::run_campaign(other, o);
    ADD_FAILURE() << "a resume with other seeds was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("holds a campaign of another CALIB file"), std::string::npos) << e.what();
  }
}

TEST(CalibCampaign, AFailedTestScoresTheEvaluationAsFailed) {
  const auto c = micro();
  const std::string d = fresh_dir("calib_model_failed");
  calib::CampaignOptions o;
  o.out_dir = d;
  o.runner = [](const calib::TestJob& j) {
    calib::TestRun r = model(j, nullptr);
    if (j.test == 1 && j.evaluation == 2) {
      r.rc = 2;  // the shear box of the third evaluation of each batch fails (biodem's status for a failed run)
      r.responses.clear();
    }
    return r;
  };
  calib::run_campaign(c, o);
  const auto rows = calib::read_evaluations(d + "/evaluations.csv", 3, 2);
  ASSERT_EQ(rows.size(), 16u);
  for (const auto& e : rows) {
    // Generation 1 may ask again for a failed vector of generation 0 (answered from the cache).
    if (e.generation == 0) {
      EXPECT_EQ(e.o1 == 1e9, e.index == 2) << e.index;
    }
    EXPECT_EQ(e.o1 == 1e9 && e.o2 == 1e9, std::isnan(e.responses[1])) << e.generation << " " << e.index;
  }
  EXPECT_NE(slurp(d + "/campaign.log").find("shear_box failed"), std::string::npos);
}

// A failure that says nothing of the parameters stops the campaign before its batch is scored,
// with one line naming the run: a test run killed (status 128 + 9), an internal error (3), one
// that could not write its outputs (4, its message in stdout.txt), one that could not be
// started (-1). Before, each was scored 1e9 and cached, so --resume kept it for good. --resume
// then ends with the files of an uninterrupted campaign.
TEST(CalibCampaign, AFailureThatSaysNothingOfTheParametersStopsTheCampaignUnscored) {
  const auto c = micro();
  const std::string ref = fresh_dir("calib_model_unscorable_ref");
  run(c, ref, 1, false);
  struct Case {
    int rc;
    std::string stdout_text, names;
  };
  const std::vector<Case> cases = {
      {128 + 9, "", "was ended by signal 9"},
      {3, "biodem: internal error: something\n", "ended with status 3"},
      {4, "biodem: error: out/trace.csv: write failed (disk full, or a file size limit?)\n", "could not write its outputs"},
      {4, "biodem: error: --out x: another biodem run is writing to this folder (x/.biodem.lock is locked)\n",
       "could not write its outputs"},
      {-1, "", "could not be started"},
  };
  for (const auto& k : cases) {
    const std::string d = fresh_dir("calib_model_unscorable");
    calib::CampaignOptions o;
    o.out_dir = d;
    o.jobs = 2;
    o.runner = [&k](const calib::TestJob& j) {
      calib::TestRun r = model(j, nullptr);
      if (j.test == 1 && j.evaluation == 5) {
        fs::create_directories(j.dir);
        std::ofstream(j.dir + "/stdout.txt") << k.stdout_text;
        r.rc = k.rc;
        r.responses.clear();
      }
      return r;
    };
    try {
      calib::run_campaign(c, o);
      ADD_FAILURE() << k.names << ": the campaign went on";
    } catch (const Error& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find(k.names), std::string::npos) << m;
      EXPECT_NE(m.find("runs/g0/e5/shear_box"), std::string::npos) << m;
      EXPECT_NE(m.find("continue with --resume"), std::string::npos) << m;
      EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
    EXPECT_EQ(calib::read_evaluations(d + "/cache.csv", 3, 2).size(), 0u) << k.names << ": a batch was scored";
    run(c, d, 2, true);
    EXPECT_EQ(without_wall(ref + "/evaluations.csv"), without_wall(d + "/evaluations.csv")) << k.names;
    EXPECT_EQ(without_wall(ref + "/pareto.csv"), without_wall(d + "/pareto.csv")) << k.names;
  }
}

// A test run that crashes again after a resume (its parameters crash it: the same signal, or an
// internal error) is scored as failed, so that the campaign can finish; its first crash stopped
// the campaign unscored. Outputs that could not be written stop it every time.
TEST(CalibCampaign, ARunCrashingAgainAfterAResumeIsScoredAsFailed) {
  const auto c = micro();
  const std::string d = fresh_dir("calib_model_crash_twice");
  auto crashing = [](const calib::TestJob& j) {
    calib::TestRun r = model(j, nullptr);
    if (j.test == 1 && j.evaluation == 5) {
      r.rc = 128 + 11;  // SIGSEGV, every time
      r.responses.clear();
    }
    return r;
  };
  calib::CampaignOptions o;
  o.out_dir = d;
  o.runner = crashing;
  EXPECT_THROW(calib::run_campaign(c, o), Error);
  EXPECT_TRUE(fs::exists(d + "/runs/g0/e5/shear_box/crashed_once"));
  o.resume = true;
  // The crash again: scored as failed; generation 1's e5 crashes a first time too (a new run),
  // then a second: three attempts in all, and the campaign ends.
  EXPECT_THROW(calib::run_campaign(c, o), Error);
  calib::run_campaign(c, o);
  const auto rows = calib::read_evaluations(d + "/evaluations.csv", 3, 2);
  ASSERT_EQ(rows.size(), 16u);
  EXPECT_EQ(rows[5].o1, 1e9);
  EXPECT_EQ(rows[5].o2, 1e9);
  EXPECT_NE(slurp(d + "/campaign.log").find("crashed again after a resume (status 139): scored as failed"), std::string::npos);

  // Outputs that could not be written: a stop at every attempt.
  const std::string w = fresh_dir("calib_model_write_twice");
  o = {};
  o.out_dir = w;
  o.runner = [](const calib::TestJob& j) {
    calib::TestRun r = model(j, nullptr);
    if (j.test == 1 && j.evaluation == 5) {
      fs::create_directories(j.dir);
      std::ofstream(j.dir + "/stdout.txt") << "biodem: error: x/series.csv: writing 'x/series.csv' failed\n";
      r.rc = 4;
      r.responses.clear();
    }
    return r;
  };
  EXPECT_THROW(calib::run_campaign(c, o), Error);
  // (not a crash: no mark that would spend the run's one retry of a crash)
  EXPECT_FALSE(fs::exists(w + "/runs/g0/e5/shear_box/crashed_once"));
  o.resume = true;
  EXPECT_THROW(calib::run_campaign(c, o), Error);
  EXPECT_FALSE(fs::exists(w + "/runs/g0/e5/shear_box/crashed_once"));
  EXPECT_EQ(slurp(w + "/campaign.log").find("crashing again"), std::string::npos);
}

// campaign.id names the build that started the campaign; a --resume by another build says in
// campaign.log (and on stderr) that the cached evaluations were made by that one.
TEST(CalibCampaign, AResumeByAnotherBuildIsWarnedAbout) {
  const auto c = micro();
  const std::string d = fresh_dir("calib_model_build");
  run(c, d, 1, false);
  const std::string id = slurp(d + "/campaign.id");
  const auto eol = id.find('\n');
  ASSERT_NE(eol, std::string::npos);
  EXPECT_EQ(id.substr(eol + 1, 14), "build: biodem ") << id;
  EXPECT_EQ(slurp(d + "/campaign.log").find("made by another build"), std::string::npos);
  run(c, d, 1, true);  // the same build: nothing to say
  EXPECT_EQ(slurp(d + "/campaign.log").find("made by another build"), std::string::npos);
  std::ofstream(d + "/campaign.id") << id.substr(0, eol + 1) << "build: biodem 0.0.1 (source 0123456789ab; other)\n";
  run(c, d, 1, true);
  EXPECT_NE(slurp(d + "/campaign.log").find("cached evaluations were made by another build (biodem 0.0.1 (source "
                                            "0123456789ab; other))"),
            std::string::npos)
      << slurp(d + "/campaign.log");
}

// An exception on a worker thread (a runner that throws) ends the campaign with its message,
// not with std::terminate; a campaign folder in use by another campaign is refused before
// anything is written or run.
TEST(CalibCampaign, AWorkerExceptionAndAFolderInUseAreOneLineErrors) {
  const auto c = micro();
  calib::CampaignOptions o;
  o.out_dir = fresh_dir("calib_model_throw");
  o.jobs = 3;
  o.runner = [](const calib::TestJob& j) -> calib::TestRun {
    if (j.evaluation == 4) throw Error("model cannot evaluate e4");
    return model(j, nullptr);
  };
  try {
    calib::run_campaign(c, o);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("model cannot evaluate e4"), std::string::npos) << e.what();
  }
  const std::string d = fresh_dir("calib_model_locked");
  fs::create_directories(d);
  const output::DirLock held = output::lock_output_dir(d);
  std::atomic<int> calls{0};
  try {
    run(c, d, 1, false, &calls);
    ADD_FAILURE() << "a second campaign ran in a folder in use";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("another biodem run is writing to this folder"), std::string::npos) << e.what();
  }
  EXPECT_EQ(calls.load(), 0);
  EXPECT_FALSE(fs::exists(d + "/cache.csv"));
}
#else
TEST(CalibCampaign, NotBuilt) { GTEST_SKIP() << "pagmo not found: the campaign is not built"; }
#endif
