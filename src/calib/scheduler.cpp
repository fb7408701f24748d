#include "calib/scheduler.hpp"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <mutex>
#include <sstream>
#include <thread>

#include "core/error.hpp"
#ifdef BIODEM_HAVE_MPI
#include <mpi.h>
#endif

namespace biodem::calib {

std::vector<TestRun> run_on_threads(const std::vector<TestJob>& jobs, int threads, const TestRunner& run) {
  std::vector<TestRun> out(jobs.size());
  std::atomic<std::size_t> next{0};
  // An exception on a worker thread would end the program (std::terminate): the first one is
  // kept, the other workers stop taking jobs, and it is thrown again here once all have joined.
  std::exception_ptr failure;
  std::mutex failure_mutex;
  auto worker = [&] {
    try {
      for (std::size_t q; (q = next.fetch_add(1)) < jobs.size();) out[q] = run(jobs[q]);
    } catch (...) {
      const std::lock_guard<std::mutex> hold(failure_mutex);
      if (!failure) failure = std::current_exception();
      next.store(jobs.size());
    }
  };
  std::vector<std::thread> pool;
  for (int k = 0; k < std::max(1, threads); ++k) pool.emplace_back(worker);
  for (auto& th : pool) th.join();
  if (failure) std::rethrow_exception(failure);
  return out;
}

#ifdef BIODEM_HAVE_MPI
namespace {

// Tags; job message: "<job id>\n<dir>\n<drum line (encode_drum_line)>\n<case text>"; result: "<job id> <rc> <wall_s>\n<name>,<value>\n...",
// then one "!<warning>\n" per warning of the run's log.
constexpr int kTagJob = 1, kTagResult = 2, kTagStop = 3;

std::string g17(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

void send_text(const std::string& s, int to, int tag) {
  MPI_Send(s.data(), static_cast<int>(s.size()), MPI_CHAR, to, tag, MPI_COMM_WORLD);
}

std::string recv_text(int from, int tag, MPI_Status& st) {
  MPI_Probe(from, tag, MPI_COMM_WORLD, &st);
  int n = 0;
  MPI_Get_count(&st, MPI_CHAR, &n);
  std::string s(static_cast<std::size_t>(n), '\0');
  MPI_Recv(s.data(), n, MPI_CHAR, st.MPI_SOURCE, st.MPI_TAG, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  return s;
}

}  // namespace

bool launched_by_mpirun() { return std::getenv("OMPI_COMM_WORLD_SIZE") != nullptr; }

MpiJob::MpiJob() {
  MPI_Init(nullptr, nullptr);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
}

MpiJob::~MpiJob() { MPI_Finalize(); }

std::vector<TestRun> MpiJob::run(const std::vector<TestJob>& jobs) const {
  std::vector<TestRun> out(jobs.size());
  std::size_t sent = 0, received = 0;
  auto send = [&](int rank) {
    const TestJob& j = jobs[sent];
    send_text(std::to_string(sent) + "\n" + j.dir + "\n" + encode_drum_line(j.drum) + "\n" + j.case_text, rank, kTagJob);
    ++sent;
  };
  for (int rank = 1; rank < size_ && sent < jobs.size(); ++rank) send(rank);
  while (received < sent) {
    MPI_Status st;
    const std::string msg = recv_text(MPI_ANY_SOURCE, kTagResult, st);
    std::istringstream in(msg);
    std::size_t id = 0;
    TestRun r;
    in >> id >> r.rc >> r.wall_s;
    std::string line;
    std::getline(in, line);
    while (std::getline(in, line)) {
      if (!line.empty() && line[0] == '!') {  // a warning of the run's log
        r.warnings.push_back(line.substr(1));
        continue;
      }
      const auto c = line.find(',');
      if (c != std::string::npos) r.responses[line.substr(0, c)] = std::stod(line.substr(c + 1));
    }
    out[id] = r;
    ++received;
    // After a campaign signal no new job is handed out (the ranks' runs in progress finish, or
    // stop if mpirun passed the signal on to them); the rest are not started.
    if (sent < jobs.size() && !CampaignSignals::received()) send(st.MPI_SOURCE);
  }
  if (const int sig = CampaignSignals::received())
    for (std::size_t q = sent; q < jobs.size(); ++q) {
      out[q].rc = 128 + sig;
      out[q].started = false;
    }
  return out;
}

void MpiJob::serve(const std::string& biodem_exe) const {
  for (;;) {
    MPI_Status st;
    MPI_Probe(0, MPI_ANY_TAG, MPI_COMM_WORLD, &st);
    if (st.MPI_TAG == kTagStop) {
      char c;
      MPI_Recv(&c, 0, MPI_CHAR, 0, kTagStop, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      return;
    }
    const std::string msg = recv_text(0, kTagJob, st);
    const auto a = msg.find('\n'), b = msg.find('\n', a + 1), c = msg.find('\n', b + 1);
    const std::string id = msg.substr(0, a), dir = msg.substr(a + 1, b - a - 1), drum = msg.substr(b + 1, c - b - 1),
                      text = msg.substr(c + 1);
    const TestRun r = run_test_process(biodem_exe, dir, text, decode_drum_line(drum));
    std::string out = id + " " + std::to_string(r.rc) + " " + g17(r.wall_s) + "\n";
    for (const auto& [k, v] : r.responses) out += k + "," + g17(v) + "\n";
    for (const auto& w : r.warnings) out += "!" + w + "\n";
    send_text(out, 0, kTagResult);
  }
}

void MpiJob::stop_workers() const {
  for (int r = 1; r < size_; ++r) MPI_Send(nullptr, 0, MPI_CHAR, r, kTagStop, MPI_COMM_WORLD);
}

#else  // no MPI in this build

bool launched_by_mpirun() { return false; }
MpiJob::MpiJob() { throw Error("this biodem is built without MPI"); }
MpiJob::~MpiJob() = default;
std::vector<TestRun> MpiJob::run(const std::vector<TestJob>&) const { return {}; }
void MpiJob::serve(const std::string&) const {}
void MpiJob::stop_workers() const {}

#endif

}  // namespace biodem::calib
