// `biodem calibrate CALIB.toml --out DIR [--jobs N] [--resume]` (SPEC 7, 11; issue 9): an
// NSGA-II campaign over case parameters. Each evaluation runs the CALIB file's bulk-test cases
// (with the parameters applied) as child processes of this same binary (`biodem run ...
// --threads 1`), reads their responses.csv and scores the two objectives. --jobs N runs N
// child processes at once; rows are written in (generation, index) order after each batch, so
// the files do not depend on N. Every finished evaluation is appended to DIR/cache.csv at once,
// so --resume after a kill re-uses it (calib/campaign.hpp).
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "commands.hpp"
#include "core/error.hpp"
#include "io/calib_file.hpp"
#include "io/plot_writer.hpp"
#ifdef BIODEM_HAVE_PAGMO
#include "calib/campaign.hpp"
#endif
#ifdef BIODEM_HAVE_MPI
#include <mpi.h>
#endif

namespace biodem::cli {

#ifdef BIODEM_HAVE_PAGMO
namespace {

namespace fs = std::filesystem;

std::string g17(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

/// All responses the objectives use, in a fixed order (o1's, then o2's new ones).
std::vector<std::string> response_names(const io::CalibConfig& c) {
  std::vector<std::string> r;
  for (const auto* o : {&c.o1, &c.o2})
    for (const auto& n : o->responses)
      if (std::find(r.begin(), r.end(), n) == r.end()) r.push_back(n);
  return r;
}

std::string header(const io::CalibConfig& c) {
  std::string h = "generation,index";
  for (const auto& p : c.parameters) h += "," + p.name;
  for (const auto& r : response_names(c)) h += "," + r;
  return h + ",o1,o2,wall_s";
}

std::string row(const calib::Evaluation& e) {
  std::string s = std::to_string(e.generation) + "," + std::to_string(e.index);
  for (double v : e.x) s += "," + g17(v);
  for (double v : e.responses) s += "," + g17(v);
  return s + "," + g17(e.o1) + "," + g17(e.o2) + "," + g17(e.wall_s);
}

/// Rows of a CSV written by row(); malformed or incomplete lines (a kill mid-write) are skipped.
std::vector<calib::Evaluation> read_rows(const std::string& path, std::size_t n_param, std::size_t n_resp) {
  std::vector<calib::Evaluation> out;
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    std::string c;
    while (std::getline(ss, c, ',')) f.push_back(c);
    if (f.size() != 2 + n_param + n_resp + 3) continue;
    try {
      calib::Evaluation e;
      e.generation = std::stoull(f[0]);
      e.index = std::stoull(f[1]);
      for (std::size_t k = 0; k < n_param; ++k) e.x.push_back(std::stod(f[2 + k]));
      for (std::size_t k = 0; k < n_resp; ++k) e.responses.push_back(std::stod(f[2 + n_param + k]));
      e.o1 = std::stod(f[2 + n_param + n_resp]);
      e.o2 = std::stod(f[3 + n_param + n_resp]);
      e.wall_s = std::stod(f[4 + n_param + n_resp]);
      out.push_back(e);
    } catch (const std::exception&) {
    }
  }
  return out;
}

double objective(const io::CalibConfig& c, const io::CalibObjective& o, const std::map<std::string, double>& r) {
  double s = 0.0, w = 0.0;
  for (std::size_t k = 0; k < o.responses.size(); ++k) {
    const auto it = r.find(o.responses[k]);
    const double t = io::target_of(c, o.responses[k]).value;
    const double v = it == r.end() ? NAN : it->second;
    s += o.weights[k] * std::abs(v - t) / std::abs(t);
    w += o.weights[k];
  }
  return w > 0.0 ? s / w : 0.0;
}

struct TestRun {
  int rc = 0;
  double wall_s = 0.0;
  std::map<std::string, double> responses;
};

// A test run of an earlier (killed) attempt at the same evaluation: same case text, and its
// run.log ends with "finished:" (written after responses.csv).
bool finished_run(const std::string& dir, const std::string& text) {
  std::ifstream c(dir + "/case.toml"), l(dir + "/out/run.log");
  if (!c || !l) return false;
  const std::string old((std::istreambuf_iterator<char>(c)), std::istreambuf_iterator<char>());
  const std::string log((std::istreambuf_iterator<char>(l)), std::istreambuf_iterator<char>());
  return old == text && log.find("\nfinished: ") != std::string::npos && fs::exists(dir + "/out/responses.csv");
}

/// Runs one bulk-test case in `dir` as a child process of this binary (or re-uses a finished run).
TestRun run_test(const std::string& dir, const std::string& text) {
  static const std::string self = fs::read_symlink("/proc/self/exe").string();
  TestRun r;
  fs::create_directories(dir);
  const auto t0 = std::chrono::steady_clock::now();
  if (!finished_run(dir, text)) {  // a run finished before a kill is re-used as it is (deterministic)
    { std::ofstream(dir + "/case.toml") << text; }
    const std::string cmd = "'" + self + "' run '" + dir + "/case.toml' --out '" + dir + "/out' --threads 1 > '" +
                            dir + "/stdout.txt' 2>&1";
    r.rc = std::system(cmd.c_str());
  }
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::ifstream in(dir + "/out/responses.csv");
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    const auto c1 = line.find(','), c2 = line.find(',', c1 + 1);
    if (c1 == std::string::npos || c2 == std::string::npos) continue;
    r.responses[line.substr(0, c1)] = std::stod(line.substr(c1 + 1, c2 - c1 - 1));
  }
  return r;
}

#ifdef BIODEM_HAVE_MPI
// MPI: rank 0 runs NSGA-II and hands each test run to the next free rank (tags below); the
// other ranks run what they are given until told to stop.
constexpr int kTagJob = 1, kTagResult = 2, kTagStop = 3;

void mpi_send_text(const std::string& s, int to, int tag) {
  MPI_Send(s.data(), static_cast<int>(s.size()), MPI_CHAR, to, tag, MPI_COMM_WORLD);
}
std::string mpi_recv_text(int from, int tag, MPI_Status& st) {
  MPI_Probe(from, tag, MPI_COMM_WORLD, &st);
  int n = 0;
  MPI_Get_count(&st, MPI_CHAR, &n);
  std::string s(static_cast<std::size_t>(n), '\0');
  MPI_Recv(s.data(), n, MPI_CHAR, st.MPI_SOURCE, st.MPI_TAG, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  return s;
}

// Job message: "<job id>\n<dir>\n<case text>"; result: "<job id> <rc> <wall_s>\n<name>,<value>\n...".
void mpi_worker() {
  for (;;) {
    MPI_Status st;
    MPI_Probe(0, MPI_ANY_TAG, MPI_COMM_WORLD, &st);
    if (st.MPI_TAG == kTagStop) {
      char c;
      MPI_Recv(&c, 0, MPI_CHAR, 0, kTagStop, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      return;
    }
    const std::string msg = mpi_recv_text(0, kTagJob, st);
    const auto a = msg.find('\n'), b = msg.find('\n', a + 1);
    const std::string id = msg.substr(0, a), dir = msg.substr(a + 1, b - a - 1), text = msg.substr(b + 1);
    const TestRun r = run_test(dir, text);
    std::string out = id + " " + std::to_string(r.rc) + " " + g17(r.wall_s) + "\n";
    for (const auto& [k, v] : r.responses) out += k + "," + g17(v) + "\n";
    mpi_send_text(out, 0, kTagResult);
  }
}

int mpi_size() {
  int n = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &n);
  return n;
}

void mpi_stop_workers() {
  for (int r = 1; r < mpi_size(); ++r) MPI_Send(nullptr, 0, MPI_CHAR, r, kTagStop, MPI_COMM_WORLD);
}
#endif

class Campaign {
 public:
  Campaign(io::CalibConfig c, std::string out, int jobs) : c_(std::move(c)), out_(std::move(out)), jobs_(jobs) {}

  int run(bool resume) {
    const std::string eval_csv = out_ + "/evaluations.csv", cache_csv = out_ + "/cache.csv";
    const auto names = response_names(c_);
    std::map<std::vector<double>, calib::Evaluation> cache;
    if (resume) {
      if (!fs::exists(cache_csv)) throw Error("--resume: " + cache_csv + " does not exist (nothing to resume)");
      for (auto& e : read_rows(cache_csv, c_.parameters.size(), names.size())) cache[e.x] = e;
    } else if (fs::exists(eval_csv) || fs::exists(cache_csv)) {
      throw Error("--out " + out_ + ": holds an earlier campaign (evaluations.csv); use --resume or another folder");
    }
    fs::create_directories(out_ + "/runs");
    log_.open(out_ + "/campaign.log", resume ? std::ios::app : std::ios::trunc);
    log_ << (resume ? "\nresumed: " : "biodem calibrate: ") << c_.source_path << "; population " << c_.population
         << ", generations " << c_.generations << ", seed " << c_.seed << ", jobs " << jobs_ << "; "
         << cache.size() << " evaluations cached\n";
    log_.flush();
    {
      std::ofstream f(cache_csv, std::ios::app);
      if (!resume) f << header(c_) << "\n";
    }
    cache_out_.open(cache_csv, std::ios::app);
    evals_.open(eval_csv, std::ios::trunc);
    evals_ << header(c_) << "\n";
    t0_ = std::chrono::steady_clock::now();

    calib::CampaignSettings s;
    for (const auto& p : c_.parameters) {
      s.lower.push_back(p.lower);
      s.upper.push_back(p.upper);
    }
    s.population = c_.population;
    s.generations = c_.generations;
    s.seed = c_.seed;
    const std::uint64_t batches = c_.generations + 1;
    std::uint64_t done = 0;
    const auto res = calib::run_nsga2(
        s, [&](std::vector<calib::Evaluation>& b) { evaluate(b); },
        [&](const std::vector<calib::Evaluation>& b) {
          for (const auto& e : b) evals_ << row(e) << "\n";
          evals_.flush();
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
    std::ofstream p(out_ + "/pareto.csv", std::ios::trunc);
    p << header(c_) << "\n";
    for (const auto& e : res.pareto) p << row(e) << "\n";
    if (!p) throw Error(out_ + "/pareto.csv: cannot write");
    plots(res);
    log_ << "finished: " << res.evaluations.size() << " evaluations, " << res.pareto.size()
         << " in the Pareto set (pareto.csv)\n";
    std::cout << "calibrate: done; " << res.pareto.size() << " Pareto points in " << out_ << "/pareto.csv\n";
    return 0;
  }

 private:
  // One evaluation's test runs are independent child processes; a pool of jobs_ threads starts
  // them (evaluation x test), then each evaluation is scored.
  void evaluate(std::vector<calib::Evaluation>& batch) {
    const auto names = response_names(c_);
    struct Job {
      std::size_t e, t;
    };
    std::vector<Job> todo;
    for (std::size_t e = 0; e < batch.size(); ++e)
      for (std::size_t t = 0; t < c_.tests.size(); ++t) todo.push_back({e, t});
    std::vector<std::map<std::string, double>> responses(batch.size());
    std::vector<double> wall(batch.size(), 0.0);
    std::vector<std::string> errors(batch.size());
    auto dir_of = [&](const Job& j) {
      return out_ + "/runs/g" + std::to_string(batch[j.e].generation) + "/e" + std::to_string(batch[j.e].index) + "/" +
             c_.tests[j.t].name;
    };
    auto record = [&](const Job& j, const TestRun& r) {
      for (const auto& [k, v] : r.responses) responses[j.e][k] = v;
      wall[j.e] += r.wall_s;
      if (r.rc != 0) errors[j.e] += " " + c_.tests[j.t].name + " failed (see " + dir_of(j) + "/stdout.txt)";
    };
#ifdef BIODEM_HAVE_MPI
    if (mpi_ranks_ > 1) {
      std::size_t sent = 0, received = 0;
      auto send = [&](int rank) {
        const Job& j = todo[sent];
        mpi_send_text(std::to_string(sent) + "\n" + dir_of(j) + "\n" + io::apply_parameters(c_, c_.tests[j.t], batch[j.e].x),
                      rank, kTagJob);
        ++sent;
      };
      for (int rank = 1; rank < mpi_ranks_ && sent < todo.size(); ++rank) send(rank);
      while (received < sent) {
        MPI_Status st;
        const std::string msg = mpi_recv_text(MPI_ANY_SOURCE, kTagResult, st);
        std::istringstream in(msg);
        std::size_t id = 0;
        TestRun r;
        in >> id >> r.rc >> r.wall_s;
        std::string line;
        std::getline(in, line);
        while (std::getline(in, line)) {
          const auto c = line.find(',');
          if (c != std::string::npos) r.responses[line.substr(0, c)] = std::stod(line.substr(c + 1));
        }
        record(todo[id], r);
        ++received;
        if (sent < todo.size()) send(st.MPI_SOURCE);
      }
    } else
#endif
    {
      std::mutex mu;
      std::atomic<std::size_t> next{0};
      auto worker = [&] {
        for (std::size_t q; (q = next.fetch_add(1)) < todo.size();) {
          const Job& j = todo[q];
          const TestRun r = run_test(dir_of(j), io::apply_parameters(c_, c_.tests[j.t], batch[j.e].x));
          std::lock_guard<std::mutex> lock(mu);
          record(j, r);
        }
      };
      std::vector<std::thread> pool;
      for (int k = 0; k < std::max(1, jobs_); ++k) pool.emplace_back(worker);
      for (auto& th : pool) th.join();
    }
    for (std::size_t e = 0; e < batch.size(); ++e) {
      auto& ev = batch[e];
      ev.responses.clear();
      for (const auto& n : names) ev.responses.push_back(responses[e].count(n) ? responses[e][n] : NAN);
      ev.o1 = objective(c_, c_.o1, responses[e]);
      ev.o2 = objective(c_, c_.o2, responses[e]);
      if (!errors[e].empty() || !std::isfinite(ev.o1) || !std::isfinite(ev.o2)) {
        log_ << "evaluation g" << ev.generation << " e" << ev.index << ":" << errors[e]
             << " - scored as o1 = o2 = 1e9\n";
        ev.o1 = ev.o2 = 1e9;
      }
      ev.wall_s = wall[e];
      cache_out_ << row(ev) << "\n";
    }
    cache_out_.flush();
  }

  void plots(const calib::CampaignResult& r) {
    io::Plot pf;
    pf.title = "Pareto front";
    pf.x_label = "o1 (relative error)";
    pf.y_label = "o2 (relative error)";
    io::PlotSeries all{"all evaluations", {}, {}, io::PlotStyle::markers};
    io::PlotSeries front{"Pareto set", {}, {}, io::PlotStyle::markers};
    front.marker = io::Marker::triangle_up;
    front.marker_size = 6.0;
    for (const auto& e : r.evaluations)
      if (e.o1 < 1e9) {
        all.x.push_back(e.o1);
        all.y.push_back(e.o2);
      }
    for (const auto& e : r.pareto) {
      front.x.push_back(e.o1);
      front.y.push_back(e.o2);
    }
    pf.series = {all, front};
    io::write_plot(pf, out_ + "/pareto");
    const auto names = response_names(c_);
    for (std::size_t i = 0; i < names.size(); ++i)
      for (std::size_t k = 0; k < c_.parameters.size(); ++k) {
        io::Plot p;
        p.title = names[i] + " vs " + c_.parameters[k].name;
        p.x_label = c_.parameters[k].name;
        p.y_label = names[i];
        io::PlotSeries s{"evaluations", {}, {}, io::PlotStyle::markers};
        for (const auto& e : r.evaluations)
          if (std::isfinite(e.responses[i])) {
            s.x.push_back(e.x[k]);
            s.y.push_back(e.responses[i]);
          }
        io::PlotSeries t{"target", {c_.parameters[k].lower, c_.parameters[k].upper},
                         {io::target_of(c_, names[i]).value, io::target_of(c_, names[i]).value}};
        p.series = {s, t};
        io::write_plot(p, out_ + "/" + names[i] + "_vs_" + c_.parameters[k].name);
      }
  }

  io::CalibConfig c_;
  std::string out_;
  int jobs_;
 public:
  int mpi_ranks_ = 1;  // > 1: test runs go to MPI ranks 1 .. n-1
 private:
  std::ofstream log_, evals_, cache_out_;
  std::chrono::steady_clock::time_point t0_;
};

}  // namespace
#endif

Action register_calibrate(CLI::App& app) {
  auto* sub = app.add_subcommand("calibrate", "Bulk-test calibration campaign (NSGA-II over case parameters)");
  static std::string calib_path, out_dir;
  static int jobs = 1;
  static bool resume = false;
  sub->add_option("CALIB", calib_path, "calibration file (TOML)")->required();
  sub->add_option("--out", out_dir, "output directory")->required();
  sub->add_option("--jobs", jobs, "evaluations run at once on this machine (child processes)")
      ->check(CLI::PositiveNumber);
  sub->add_flag("--resume", resume, "re-use the finished evaluations of an interrupted campaign in --out");
  return [] {
#ifdef BIODEM_HAVE_PAGMO
#ifdef BIODEM_HAVE_MPI
    // Under mpirun (OpenMPI sets OMPI_COMM_WORLD_SIZE): rank 0 runs the campaign, the others
    // run test cases. Without mpirun, no MPI at all.
    if (std::getenv("OMPI_COMM_WORLD_SIZE")) {
      MPI_Init(nullptr, nullptr);
      int rank = 0;
      MPI_Comm_rank(MPI_COMM_WORLD, &rank);
      if (rank != 0) {
        mpi_worker();
        MPI_Finalize();
        return 0;
      }
      int status = 0;
      try {
        io::CalibConfig c = io::load_calib(calib_path);
        Campaign campaign(std::move(c), out_dir, jobs);
        campaign.mpi_ranks_ = mpi_size();
        status = campaign.run(resume);
      } catch (...) {
        mpi_stop_workers();
        MPI_Finalize();
        throw;
      }
      mpi_stop_workers();
      MPI_Finalize();
      return status;
    }
#endif
    io::CalibConfig c = io::load_calib(calib_path);
    Campaign campaign(std::move(c), out_dir, jobs);
    return campaign.run(resume);
#else
    std::cerr << "biodem: error: calibrate is not built (pagmo, libpagmo-dev, was not found at build time)\n";
    return 2;
#endif
  };
}

}  // namespace biodem::cli
