#include "calib/campaign.hpp"

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <csignal>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>

#include "calib/campaign_plots.hpp"
#include "calib/evaluations_csv.hpp"
#include "calib/nsga2.hpp"
#include "calib/objectives.hpp"
#include "calib/scheduler.hpp"
#include "core/error.hpp"
#include "output/build_info.hpp"
#include "output/output_dir.hpp"

namespace biodem::calib {
namespace {

namespace fs = std::filesystem;

// What a campaign folder was made by (DIR/campaign.id): the mode (a search, or --evaluate) and a
// fingerprint (FNV-1a, 64 bits) of everything that decides an evaluation's responses and
// objectives: the tests' case texts and drum analysis options, the targets, the objectives and
// the parameters (and, for a search, population, generations and seed). --resume with another
// mode or file would take cached evaluations for ones of this file, or overwrite the other
// mode's results, so it is refused.
std::string campaign_id(const CalibConfig& c, bool evaluate) {
  std::ostringstream t;
  t.precision(17);
  for (const auto& test : c.tests) {
    t << "test " << test.name << '\n' << test.case_text << '\n' << encode_drum_line(test.drum) << '\n';
    if (!test.seeds.empty()) {  // (only then: the folders of files without seeds keep their id)
      t << "seeds";
      for (const auto s : test.seeds) t << ' ' << s;
      t << '\n';
    }
  }
  for (const auto& g : c.targets) t << "target " << g.response << ' ' << g.value << ' ' << g.unit << '\n';
  for (const auto* o : {&c.o1, &c.o2}) {
    t << "objective";
    for (std::size_t k = 0; k < o->responses.size(); ++k) t << ' ' << o->responses[k] << ' ' << o->weights[k];
    t << '\n';
  }
  for (const auto& p : c.parameters) {
    t << "parameter " << p.name << ' ' << p.lower << ' ' << p.upper;
    for (const auto& k : p.keys) t << ' ' << k.path << ' ' << k.factor;
    t << '\n';
  }
  if (!evaluate) t << "search " << c.population << ' ' << c.generations << ' ' << c.seed << '\n';
  std::uint64_t h = 14695981039346656037ull;
  for (const unsigned char ch : t.str()) h = (h ^ ch) * 1099511628211ull;
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return std::string(evaluate ? "evaluate " : "search ") + hex;
}

// A campaign file that could not be written (a full disk, a file size limit) stops the campaign
// with one line, instead of a "done" over files that miss rows.
void check_written(std::ostream& f, const std::string& path) {
  if (!f) throw OutputError(path + ": write failed (disk full, or a file size limit?)");
}

class Campaign {
 public:
  Campaign(const CalibConfig& c, const CampaignOptions& o, const MpiJob* mpi) : c_(c), o_(o), mpi_(mpi) {
    if (!o_.runner) {
      const std::string exe = o_.biodem_exe.empty() ? current_executable() : o_.biodem_exe;
      o_.runner = [exe](const TestJob& j) { return run_test_process(exe, j.dir, j.case_text, j.drum); };
    }
  }

  CampaignSummary run() {
    const std::string& out = o_.out_dir;
    // --evaluate: the vectors are read (and checked) before anything is written or run.
    std::vector<std::vector<double>> given;
    if (!o_.evaluate_csv.empty()) given = read_parameter_rows(o_.evaluate_csv, c_);
    // One campaign per folder: a second one (or a --resume while the test runs of a killed one
    // still run: they hold the lock too) would run the same test folders at once, and score the
    // runs refused by their own folders' locks as failures, for good.
    output::prepare_output_dir(out, "--out");  // (made, writable, or one line with status 4)
    const output::DirLock lock = output::lock_output_dir(out, /*inherited_by_children=*/true);
    const CampaignSignals signals;  // SIGINT / SIGTERM stop the campaign, not just its test runs
    const std::string eval_csv = out + "/evaluations.csv", cache_csv = out + "/cache.csv";
    const auto names = response_names(c_);
    std::map<std::vector<double>, Evaluation> cache;
    const std::string id_file = out + "/campaign.id", id = campaign_id(c_, !given.empty());
    if (o_.resume) {
      if (!fs::exists(cache_csv)) throw Error("--resume: " + cache_csv + " does not exist (nothing to resume)");
      std::string was;  // (a folder of a build before campaign.id: a search of the same file is assumed)
      if (std::ifstream f(id_file); f) {
        std::getline(f, was);
        std::getline(f, made_by_);  // "build: ..." (a campaign.id of a build before it has none)
      }
      if (!was.empty() && was.substr(0, was.find(' ')) != id.substr(0, id.find(' ')))
        throw Error("--resume: " + out + " holds " +
                    (was.rfind("search", 0) == 0 ? std::string("a search (NSGA-II) campaign; --evaluate")
                                                 : std::string("an --evaluate campaign; a search")) +
                    " needs another folder");
      if (!was.empty() && was != id)
        throw Error("--resume: " + out + " holds a campaign of another CALIB file (its tests, drum options, targets, "
                    "objectives, parameters or search settings differ from " + c_.source_path +
                    "): its cached evaluations are not this file's; use another folder");
      for (auto& e : read_evaluations(cache_csv, c_.parameters.size(), names.size())) cache[e.x] = e;
    } else if (fs::exists(eval_csv) || fs::exists(cache_csv)) {
      throw Error("--out " + out + ": holds an earlier campaign (evaluations.csv); use --resume or another folder");
    }
    if (std::error_code ec; fs::create_directories(out + "/runs", ec), ec)
      throw OutputError("--out " + out + ": cannot create the folder runs (" + ec.message() + ")");
    const std::string build = "build: " + output::build_description();
    if (!o_.resume || !fs::exists(id_file)) output::write_file_atomic(id_file, id + "\n" + build + "\n");
    log_.open(out + "/campaign.log", o_.resume ? std::ios::app : std::ios::trunc);
    log_ << (o_.resume ? "\nresumed: " : "biodem calibrate: ") << c_.source_path << "; ";
    if (given.empty())
      log_ << "population " << c_.population << ", generations " << c_.generations << ", seed " << c_.seed;
    else
      log_ << "evaluating the " << given.size() << " parameter vectors of " << o_.evaluate_csv << " (--evaluate, no search)";
    if (mpi_ && mpi_->size() > 1)  // the test runs go to the ranks (--jobs is not used then)
      log_ << ", MPI ranks " << mpi_->size() << " (" << mpi_->size() - 1 << " running tests)";
    else
      log_ << ", jobs " << o_.jobs;
    log_ << "; " << cache.size() << " evaluations cached\n";
    log_ << build << "\n";
    // Evaluations cached by another build (another commit, compiler or engine setting) may not be
    // what this one computes: said, not refused (a rebuild is often unrelated to the physics).
    if (o_.resume && !made_by_.empty() && made_by_ != build && !cache.empty()) {
      const std::string w = "calibrate: WARNING: the " + std::to_string(cache.size()) +
                            " cached evaluations were made by another build (" +
                            (made_by_.rfind("build: ", 0) == 0 ? made_by_.substr(7) : made_by_) +
                            "); the campaign's results may mix the two";
      log_ << w << "\n";
      std::cerr << w << "\n";
    }
    log_.flush();
    {
      std::ofstream f(cache_csv, std::ios::app);
      if (!o_.resume) f << evaluations_header(c_) << "\n";
    }
    cache_out_.open(cache_csv, std::ios::app);
    check_written(cache_out_, cache_csv);
    evals_.open(eval_csv, std::ios::trunc);
    evals_ << evaluations_header(c_) << "\n";
    check_written(evals_, eval_csv);
    check_written(log_, out + "/campaign.log");
    t0_ = std::chrono::steady_clock::now();

    CampaignSettings s;
    for (const auto& p : c_.parameters) {
      s.lower.push_back(p.lower);
      s.upper.push_back(p.upper);
    }
    s.population = c_.population;
    s.generations = c_.generations;
    s.seed = c_.seed;
    const std::uint64_t batches = given.empty() ? c_.generations + 1 : 1;
    std::uint64_t done = 0;
    const auto res = !given.empty() ? evaluate_given(given, cache) : run_nsga2(
        s, [&](std::vector<Evaluation>& b) { evaluate(b); },
        [&](const std::vector<Evaluation>& b) {
          for (const auto& e : b) evals_ << evaluation_row(e) << "\n";
          evals_.flush();
          check_written(evals_, out + "/evaluations.csv");
          ++done;
          const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
          double best1 = INFINITY, best2 = INFINITY;
          for (const auto& e : b) {
            best1 = std::min(best1, e.o1);
            best2 = std::min(best2, e.o2);
          }
          log_ << "generation " << b.front().generation << " done (" << done << " of " << batches
               << " batches): best o1 " << best1 << ", best o2 " << best2 << "; elapsed " << el << " s, ETA "
               << el / static_cast<double>(done) * static_cast<double>(batches - done) << " s\n";
          log_.flush();
          std::cerr << "calibrate: batch " << done << " of " << batches << " done\n";
        },
        cache);
    std::ostringstream p;
    p << evaluations_header(c_) << "\n";
    for (const auto& e : res.pareto) p << evaluation_row(e) << "\n";
    output::write_file_atomic(out + "/pareto.csv", p.str());
    write_campaign_plots(c_, res, out);
    log_ << "finished: " << res.evaluations.size() << " evaluations, " << res.pareto.size()
         << " in the Pareto set (pareto.csv)\n";
    if (warned_runs_ || no_heap_runs_) {
      std::ostringstream note;
      note << "calibrate: " << warned_runs_ << " warnings of test runs and " << no_heap_runs_
           << " heaps not found in the evaluations run now; see campaign.log";
      log_ << note.str() << "\n";
      std::cerr << note.str() << "\n";
    }
    log_.flush();
    check_written(log_, out + "/campaign.log");
    return {res.evaluations.size(), res.pareto.size()};
  }

 private:
  // Every (evaluation, test, seed) of the batch is one job (one seed: the case's own, unless the
  // [[test]] gives seeds); the jobs run on threads or MPI ranks, then each evaluation is scored
  // from its tests' responses (in test order; a test's responses are the means over its seeds).
  void evaluate(std::vector<Evaluation>& batch) {
    const auto names = response_names(c_);
    std::vector<TestJob> jobs;
    std::vector<std::size_t> seed_of;  // the job's position in its test's seeds (0 without seeds)
    for (std::size_t e = 0; e < batch.size(); ++e)
      for (std::size_t t = 0; t < c_.tests.size(); ++t) {
        const CalibTest& test = c_.tests[t];
        const std::string text = apply_parameters(c_, test, batch[e].x);
        const std::string dir = o_.out_dir +
                                (o_.evaluate_csv.empty() ? "/runs/g" + std::to_string(batch[e].generation) : std::string("/runs/evaluate")) +
                                "/e" + std::to_string(batch[e].index) + "/" + test.name;
        for (std::size_t s = 0; s < std::max<std::size_t>(1, test.seeds.size()); ++s) {
          TestJob j;
          j.evaluation = e;
          j.test = t;
          // (a seed's run in a folder inside the test's: test names have no slash, so no other
          // test's folder can be the same)
          j.dir = test.seeds.empty() ? dir : dir + "/seed" + std::to_string(test.seeds[s]);
          j.case_text = test.seeds.empty() ? text : with_seed(text, test.seeds[s]);
          j.drum = test.drum;
          j.x = batch[e].x;
          jobs.push_back(std::move(j));
          seed_of.push_back(s);
        }
      }
    const std::vector<TestRun> runs = mpi_ && mpi_->size() > 1 ? mpi_->run(jobs) : run_on_threads(jobs, o_.jobs, o_.runner);
    // Stopped by a signal (the campaign's, or a test run's own): nothing of this batch is scored.
    int sig = CampaignSignals::received();
    std::size_t stopped = 0, unstarted = 0;
    for (const TestRun& r : runs)
      if (const int s = stopping_signal(r.rc)) {
        ++(r.started ? stopped : unstarted);
        if (!sig) sig = s;
      }
    if (sig) {
      const std::string name = sig == SIGINT ? "SIGINT" : "SIGTERM";
      const std::string what = "calibrate: stopped by " + name + " in generation " +
                               std::to_string(batch.front().generation) + " (" + std::to_string(stopped) +
                               " test runs stopped, " + std::to_string(unstarted) +
                               " not started; this generation is not scored); continue with --resume";
      log_ << what << "\n";
      log_.flush();
      throw CampaignStopped(sig, what);
    }
    // A failure that says nothing of the parameters (a kill, an internal error, outputs that
    // could not be written) stops the campaign before this batch is scored: cached as 1e9 it
    // would stay so on every --resume. The runs that finished are re-used by --resume. A crash
    // (signal, internal error, not started) leaves a mark in its folder: the same run crashing
    // again after a resume is scored as failed (its parameters crash it), so that the campaign
    // can finish.
    std::string stop;
    bool stop_is_output = false;  // the first unscorable run could not write its outputs (status 4)
    for (std::size_t q = 0; q < jobs.size(); ++q) {
      const TestRun& r = runs[q];
      const std::string marker = jobs[q].dir + "/crashed_once";
      const bool crash = r.rc != 0 && r.rc != 2 && r.rc != 4 && !stopping_signal(r.rc);  // (4: outputs not written)
      const bool before = crash && fs::exists(marker);
      const std::string why = unscorable_failure(r, jobs[q].dir, before);
      if (!why.empty()) {
        if (crash) {
          std::error_code ec;
          fs::create_directories(jobs[q].dir, ec);
          std::ofstream(marker) << r.rc << "\n";
        }
        if (stop.empty()) stop_is_output = r.rc == 4;
        if (stop.empty())
          stop = "calibrate: the test run in " + jobs[q].dir + " " + why + "; generation " +
                 std::to_string(batch.front().generation) + " is not scored; remove the cause and continue with --resume" +
                 (crash ? " (the same run crashing again is scored as failed)" : "");
      } else if (before) {
        log_ << "evaluation g" << batch[jobs[q].evaluation].generation << " e" << batch[jobs[q].evaluation].index << " "
             << c_.tests[jobs[q].test].name << ": crashed again after a resume (status " << r.rc
             << "): scored as failed (" << jobs[q].dir << ")\n";
      }
    }
    if (!stop.empty()) {
      log_ << stop << "\n";
      log_.flush();
      if (stop_is_output) throw OutputError(stop);
      throw Error(stop);
    }
    std::vector<std::map<std::string, double>> responses(batch.size());
    std::vector<double> wall(batch.size(), 0.0);
    std::vector<std::string> errors(batch.size());
    // Each (evaluation, test): each response's values over the test's runs (one, or one per seed
    // in seed order; NaN where a run lacks it), then their mean (the one value itself without
    // seeds), merged into the evaluation's responses in test order.
    std::vector<std::vector<std::map<std::string, std::vector<double>>>> per_test(
        batch.size(), std::vector<std::map<std::string, std::vector<double>>>(c_.tests.size()));
    for (std::size_t q = 0; q < jobs.size(); ++q) {
      const TestJob& j = jobs[q];
      const TestRun& r = runs[q];
      const std::size_t n_runs = std::max<std::size_t>(1, c_.tests[j.test].seeds.size());
      for (const auto& [k, v] : r.responses) {
        auto& vs = per_test[j.evaluation][j.test][k];
        vs.resize(n_runs, NAN);
        vs[seed_of[q]] = v;
      }
      wall[j.evaluation] += r.wall_s;
      if (r.rc != 0)
        errors[j.evaluation] += " " + c_.tests[j.test].name + " failed (status " + std::to_string(r.rc) + "; see " + j.dir +
                                "/stdout.txt)";
      // What the responses may not mean: the run's warnings, and a heap that was not found (its
      // angle is scored as 0).
      const std::string who = "evaluation g" + std::to_string(batch[j.evaluation].generation) + " e" +
                              std::to_string(batch[j.evaluation].index) + " " + c_.tests[j.test].name + ": ";
      for (const auto& w : r.warnings) {
        const bool analysis = w.rfind("WARNING: drum test:", 0) == 0;  // (measure_drum's, not the run's)
        log_ << who << w << " (" << j.dir << (analysis ? "/out/series.csv" : "/out/run.log") << ")\n";
        ++warned_runs_;
      }
      if (const auto h = r.responses.find("heap_found"); h != r.responses.end() && h->second == 0.0) {
        log_ << who << "no heap found (heap_found = 0): angle_of_repose_deg = 0 is scored"
             << (c_.tests[j.test].seeds.empty() ? "" : " (in the mean over the seeds)") << " (" << j.dir << ")\n";
        ++no_heap_runs_;
      }
    }
    for (std::size_t e = 0; e < batch.size(); ++e)
      for (std::size_t t = 0; t < c_.tests.size(); ++t) {
        const CalibTest& test = c_.tests[t];
        const auto& values = per_test[e][t];
        const std::size_t n = std::max<std::size_t>(1, test.seeds.size());
        for (const auto& [k, vs] : values) {
          // The mean over the runs (without seeds the one value itself, as it came); a run that
          // lacks the response (NaN in its place) leaves it missing, so an objective that needs
          // it fails.
          double sum = 0.0;
          for (const double v : vs) sum += v;
          responses[e][k] = n == 1 ? vs[0] : sum / static_cast<double>(n);
        }
        if (test.seeds.empty()) continue;
        // The targets' responses seed by seed, with their mean and sample standard deviation: how
        // much of an objective is the seed's.
        std::ostringstream line;
        line.precision(6);
        line << "evaluation g" << batch[e].generation << " e" << batch[e].index << " " << test.name << ", seeds";
        for (const auto sd : test.seeds) line << ' ' << sd;
        line << ':';
        bool any = false;
        for (const auto& g : c_.targets) {
          const auto it = values.find(g.response);
          if (it == values.end()) continue;
          const std::vector<double>& vs = it->second;
          double mean = 0.0, ss = 0.0;
          for (const double v : vs) mean += v;
          mean /= static_cast<double>(n);
          for (const double v : vs) ss += (v - mean) * (v - mean);
          line << (any ? "; " : " ") << g.response;
          for (const double v : vs) line << ' ' << v;
          line << " (mean " << mean;
          if (n > 1) line << ", sd " << std::sqrt(ss / static_cast<double>(n - 1));
          line << ')';
          any = true;
        }
        if (any) log_ << line.str() << '\n';
      }
    for (std::size_t e = 0; e < batch.size(); ++e) {
      auto& ev = batch[e];
      ev.responses.clear();
      for (const auto& n : names) ev.responses.push_back(responses[e].count(n) ? responses[e][n] : NAN);
      ev.o1 = objective(c_, c_.o1, responses[e]);
      ev.o2 = objective(c_, c_.o2, responses[e]);
      if (errors[e].empty() && (!std::isfinite(ev.o1) || !std::isfinite(ev.o2))) {
        std::string missing;  // the responses an objective needs and the tests did not give
        for (const auto* o : {&c_.o1, &c_.o2})
          for (const auto& n : o->responses)
            if ((!responses[e].count(n) || !std::isfinite(responses[e][n])) &&
                missing.find(" " + n + ",") == std::string::npos)
              missing += " " + n + ",";
        if (!missing.empty()) errors[e] = " no value of" + missing.substr(0, missing.size() - 1);
      }
      if (!errors[e].empty() || !std::isfinite(ev.o1) || !std::isfinite(ev.o2)) {
        log_ << "evaluation g" << ev.generation << " e" << ev.index << ":" << errors[e]
             << " - scored as o1 = o2 = 1e9\n";
        ev.o1 = ev.o2 = 1e9;
      }
      ev.wall_s = wall[e];
      cache_out_ << evaluation_row(ev) << "\n";
    }
    cache_out_.flush();
    check_written(cache_out_, o_.out_dir + "/cache.csv");
  }

  // --evaluate: one batch of the given vectors (generation 0, index = row); those in the cache of
  // an interrupted attempt (--resume) are not run again.
  CampaignResult evaluate_given(const std::vector<std::vector<double>>& given,
                                std::map<std::vector<double>, Evaluation>& cache) {
    std::vector<Evaluation> all(given.size()), todo;
    for (std::size_t i = 0; i < given.size(); ++i) {
      all[i].index = i;
      all[i].x = given[i];
      if (const auto it = cache.find(given[i]); it != cache.end()) {
        all[i] = it->second;
        all[i].generation = 0;
        all[i].index = i;
      } else {
        todo.push_back(all[i]);
      }
    }
    evaluate(todo);
    for (const auto& e : todo) {
      all[e.index] = e;
      cache[e.x] = e;
    }
    for (const auto& e : all) evals_ << evaluation_row(e) << "\n";
    evals_.flush();
    check_written(evals_, o_.out_dir + "/evaluations.csv");
    double best1 = INFINITY, best2 = INFINITY;
    for (const auto& e : all) {
      best1 = std::min(best1, e.o1);
      best2 = std::min(best2, e.o2);
    }
    const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
    log_ << "evaluated " << all.size() << " vectors (" << todo.size() << " run now): best o1 " << best1 << ", best o2 "
         << best2 << "; elapsed " << el << " s\n";
    log_.flush();
    std::cerr << "calibrate: " << all.size() << " vectors evaluated\n";
    CampaignResult r;
    r.evaluations = all;
    std::vector<Evaluation> scored;  // failed rows (1e9) are no candidates of the narrowed set
    for (const auto& e : all)
      if (e.o1 < 1e9 && e.o2 < 1e9) scored.push_back(e);
    r.pareto = pareto_front(scored);
    if (scored.empty()) {
      log_ << "no row was scored (every evaluation failed): pareto.csv is empty\n";
      std::cerr << "calibrate: no row was scored (every evaluation failed; see campaign.log)\n";
    }
    return r;
  }

  const CalibConfig& c_;
  CampaignOptions o_;
  const MpiJob* mpi_;
  std::ofstream log_, evals_, cache_out_;
  std::size_t warned_runs_ = 0, no_heap_runs_ = 0;  // warnings of the test runs; heaps not found
  std::string made_by_;  // campaign.id's second line: the build that started the campaign
  std::chrono::steady_clock::time_point t0_;
};

}  // namespace

CampaignSummary run_campaign(const CalibConfig& c, const CampaignOptions& options, const MpiJob* mpi) {
  return Campaign(c, options, mpi).run();
}

CampaignSummary calibrate(const std::string& calib_path, const CampaignOptions& options) {
  if (launched_by_mpirun()) {
    // Rank 0 runs the campaign, the others run test cases until it is over (also after an error).
    MpiJob mpi;
    if (mpi.rank() != 0) {
      mpi.serve(options.biodem_exe.empty() ? current_executable() : options.biodem_exe);
      CampaignSummary worker;
      worker.mpi_worker = true;
      return worker;
    }
    CampaignSummary s;
    try {
      s = run_campaign(load_calib(calib_path), options, &mpi);
    } catch (...) {
      mpi.stop_workers();
      throw;
    }
    mpi.stop_workers();
    return s;
  }
  return run_campaign(load_calib(calib_path), options);
}

}  // namespace biodem::calib
