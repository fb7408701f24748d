#include "driver/run_driver.hpp"

#include <omp.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <random>
#include <sstream>

#include "analysis/centroid_angle.hpp"
#include "core/error.hpp"
#include "driver/build_simulation.hpp"
#include "io/case_report.hpp"
#include "io/output_dir.hpp"
#include "io/progress.hpp"
#include "io/vtk_writer.hpp"

namespace biodem::driver {
namespace {

namespace fs = std::filesystem;

struct PhasePlan {
  std::string name;
  std::uint64_t max_steps = 0;
  bool rotate = false;
  bool criterion = false;
  double ke_threshold_j = 0.0;
  std::uint64_t min_steps = 0;
  std::uint64_t hold_steps = 1;
};

std::uint64_t steps_for(double seconds, double dt) {
  return static_cast<std::uint64_t>(std::llround(seconds / dt));
}

std::vector<PhasePlan> plan_phases(const config::CaseConfig& c) {
  std::vector<PhasePlan> out;
  const double dt = c.run.dt_s;
  for (const auto& p : c.phases) {
    PhasePlan q;
    q.name = p.name;
    q.rotate = p.rotate;
    if (p.until_mean_kinetic_energy_j) {
      q.criterion = true;
      q.ke_threshold_j = *p.until_mean_kinetic_energy_j;
      q.max_steps = steps_for(p.max_duration_s.value_or(0.0), dt);
      q.min_steps = steps_for(p.min_duration_s, dt);
      q.hold_steps = std::max<std::uint64_t>(1, steps_for(p.settle_hold_s, dt));
    } else if (p.length == config::PhaseLength::Steps) {
      q.max_steps = p.steps;
    } else if (p.length == config::PhaseLength::Duration) {
      q.max_steps = steps_for(p.duration_s, dt);
    } else {
      const double rpm = c.drum ? std::abs(c.drum->rpm) : 0.0;
      q.max_steps = steps_for(p.revolutions * 60.0 / rpm, dt);
    }
    out.push_back(q);
  }
  return out;
}

/// Series and trace rows; the CSV format is SPEC 11's.
class SeriesOut {
 public:
  explicit SeriesOut(const std::string& path) : out_(path, std::ios::trunc) {
    if (!out_) throw Error(path + ": cannot open for writing");
    out_ << "time_s,revolution,alpha_deg,surface_r2,surface_angle_deg,kinetic_energy_j,contacts\n";
  }
  void write(double t, double rev, double alpha, double r2, double ang, double ke, std::size_t contacts) {
    char buf[256];
    auto num = [](double v, char* b, std::size_t n) {
      if (std::isfinite(v)) std::snprintf(b, n, "%.10g", v);
      else b[0] = '\0';
    };
    char a[32], b[32], c[32], d[32], e[32], f[32];
    num(t, a, sizeof a);
    num(rev, b, sizeof b);
    num(alpha, c, sizeof c);
    num(r2, d, sizeof d);
    num(ang, e, sizeof e);
    num(ke, f, sizeof f);
    std::snprintf(buf, sizeof buf, "%s,%s,%s,%s,%s,%s,%zu\n", a, b, c, d, e, f, contacts);
    out_ << buf;
    if (++rows_ % 50 == 0) out_.flush();
  }
  void flush() { out_.flush(); }

 private:
  std::ofstream out_;
  std::size_t rows_ = 0;
};

class Runner {
 public:
  Runner(const io::LoadedCase& loaded, const RunOptions& opt)
      : cfg_(loaded.config), warnings_(loaded.warnings), opt_(opt), built_(build_simulation(cfg_)), sim_(*built_.sim),
        progress_(std::cerr, opt.progress_tty) {}

  RunSummary run();

 private:
  void write_log_header();
  void insert_all();
  void run_phase(const PhasePlan& p, std::size_t index);
  void after_step();
  void sample();
  void snapshot();
  double revolution() const;
  void report_progress(const std::string& label);

  const config::CaseConfig& cfg_;
  std::vector<std::string> warnings_;
  RunOptions opt_;
  BuiltCase built_;
  sim::Simulation& sim_;
  io::Progress progress_;
  std::unique_ptr<SeriesOut> series_;
  std::unique_ptr<std::ofstream> trace_;
  std::unique_ptr<io::PvdCollection> pvd_, pvd_bodies_;
  std::ofstream log_;
  std::uint64_t sample_every_ = 1, snapshot_every_ = 0;
  std::uint64_t total_steps_estimate_ = 1;
  double rotation_time_s_ = 0.0;
  std::size_t snapshot_index_ = 0;
  std::string current_phase_ = "insert";
};

double Runner::revolution() const {
  const double rpm = cfg_.drum ? std::abs(cfg_.drum->rpm) : 0.0;
  return rotation_time_s_ * rpm / 60.0;
}

void Runner::write_log_header() {
  log_ << "biodem run\ncase: " << cfg_.source_path << "\nthreads: " << omp_get_max_threads() << "\n";
  for (const auto& w : warnings_) log_ << "warning: " << w << "\n";
  log_ << "\n" << io::describe_case(cfg_) << "\n";
  log_ << "sampling: every " << sample_every_ << " steps (" << 1.0 / (sample_every_ * cfg_.run.dt_s)
       << " Hz)\n";
  log_.flush();
}

void Runner::report_progress(const std::string& label) {
  const double f = std::min(1.0, static_cast<double>(sim_.step_count()) / static_cast<double>(total_steps_estimate_));
  progress_.update(f, label, sim_.time_s());
}

void Runner::sample() {
  const auto& b = sim_.bodies();
  double m = 0.0, xc = 0.0, yc = 0.0;
  for (std::size_t i = 0; i < b.size(); ++i) {
    m += b.mass_kg[i];
    xc += b.mass_kg[i] * b.position_m[i].x;
    yc += b.mass_kg[i] * b.position_m[i].y;
  }
  const double alpha = m > 0.0 ? analysis::centroid_angle_deg(xc / m, yc / m) : std::nan("");
  const double nan = std::numeric_limits<double>::quiet_NaN();
  series_->write(sim_.time_s(), revolution(), alpha, nan, nan, sim_.kinetic_energy_j(), sim_.contact_count());
  if (trace_) {
    char buf[512];
    std::vector<std::uint32_t> by_id(b.size());
    for (std::size_t i = 0; i < b.size(); ++i) by_id[b.id[i]] = static_cast<std::uint32_t>(i);
    for (std::size_t id = 0; id < b.size(); ++id) {
      const std::size_t i = by_id[id];
      const Vec3 &x = b.position_m[i], &v = b.velocity_m_s[i], &w = b.angular_velocity_rad_s[i];
      std::snprintf(buf, sizeof buf, "%.9g,%zu,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", sim_.time_s(), id, x.x,
                    x.y, x.z, v.x, v.y, v.z, w.x, w.y, w.z);
      *trace_ << buf;
    }
  }
}

void Runner::snapshot() {
  const auto& s = sim_.spheres();
  const auto& b = sim_.bodies();
  char name[64];
  std::snprintf(name, sizeof name, "spheres_%06zu.vtu", snapshot_index_);
  io::PointCloud c;
  c.points = s.position_m;
  std::vector<double> speed(s.size());
  std::vector<std::int64_t> body(s.size()), material(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    speed[i] = norm(s.velocity_m_s[i]);
    body[i] = b.id[s.body[i]];
    material[i] = s.material[i];
  }
  c.vectors = {{"velocity", s.velocity_m_s}, {"angular_velocity", s.angular_velocity_rad_s}, {"force", s.force_n}};
  c.scalars = {{"speed", speed}, {"radius", s.radius_m}};
  c.ints = {{"body_id", body}, {"material", material}};
  io::write_vtu(opt_.out_dir + "/snapshots/" + name, c);
  pvd_->add(sim_.time_s(), std::string("snapshots/") + name);

  std::snprintf(name, sizeof name, "bodies_%06zu.vtu", snapshot_index_);
  io::PointCloud cb;
  cb.points = b.position_m;
  std::vector<double> bspeed(b.size());
  std::vector<std::int64_t> id(b.size()), shape(b.size());
  std::vector<std::array<double, 4>> q(b.size());
  for (std::size_t i = 0; i < b.size(); ++i) {
    bspeed[i] = norm(b.velocity_m_s[i]);
    id[i] = b.id[i];
    shape[i] = b.shape[i];
    q[i] = {b.orientation[i].w, b.orientation[i].x, b.orientation[i].y, b.orientation[i].z};
  }
  cb.vectors = {{"velocity", b.velocity_m_s}, {"angular_velocity", b.angular_velocity_rad_s}};
  cb.scalars = {{"speed", bspeed}, {"mass", b.mass_kg}};
  cb.ints = {{"body_id", id}, {"shape", shape}};
  cb.quats = {{"orientation", q}};
  io::write_vtu(opt_.out_dir + "/snapshots/" + name, cb);
  pvd_bodies_->add(sim_.time_s(), std::string("snapshots/") + name);
  ++snapshot_index_;
}

void Runner::after_step() {
  if (sim_.drum_rotating()) rotation_time_s_ += sim_.dt_s();
  const std::uint64_t n = sim_.step_count();
  if (n % sample_every_ == 0) sample();
  if (snapshot_every_ && n % snapshot_every_ == 0) snapshot();
  if ((n & 63) == 0) report_progress(current_phase_);
}

void Runner::insert_all() {
  if (!built_.drum || !cfg_.insertion || built_.populations.empty()) return;
  const auto& ins = *cfg_.insertion;
  const std::uint64_t count = io::implied_particle_count(cfg_);
  std::mt19937_64 rng(cfg_.run.seed);
  const auto todo = scenario::plan_population(count, built_.population_volume_fraction,
                                              built_.population_particle_volume_m3, built_.populations, rng);
  scenario::CylinderRegion region;
  region.radius_m = built_.drum->radius_m();
  region.z_min_m = 0.0;
  region.z_max_m = built_.drum->width_m;
  region.periodic_z = built_.drum->periodic_axis;
  const double fall_s = ins.wave_fall_s.value_or(std::sqrt(2.0 * built_.drum->diameter_m / 9.81));
  const std::uint64_t fall_steps = std::max<std::uint64_t>(1, steps_for(fall_s, cfg_.run.dt_s));
  std::size_t next = 0;
  int waves = 0, empty_waves = 0;
  while (next < todo.size()) {
    const std::size_t before = next;
    next = scenario::insert_wave(sim_, region, todo, next, ins.max_attempts_per_particle, rng);
    ++waves;
    log_ << "insertion wave " << waves << " at t = " << sim_.time_s() << " s: " << (next - before)
         << " particles (total " << next << " of " << todo.size() << ")\n";
    log_.flush();
    if (next == before) {
      if (++empty_waves >= 3)
        throw Error("[insertion] count = " + std::to_string(todo.size()) + ": only " + std::to_string(next) +
                    " particles could be inserted into the drum (three insertion waves in a row placed none)");
    } else {
      empty_waves = 0;
    }
    if (next < todo.size()) {
      current_phase_ = "insert";
      for (std::uint64_t k = 0; k < fall_steps; ++k) {
        sim_.step();
        after_step();
      }
    }
  }
  sim_.refresh();
}

void Runner::run_phase(const PhasePlan& p, std::size_t index) {
  current_phase_ = p.name;
  sim_.set_drum_rotation(p.rotate);
  log_ << "phase " << index + 1 << " '" << p.name << "' starts at t = " << sim_.time_s() << " s (step "
       << sim_.step_count() << "), rotation " << (p.rotate ? "on" : "off") << "\n";
  std::uint64_t below = 0, k = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (; k < p.max_steps; ++k) {
    sim_.step();
    after_step();
    if (p.criterion) {
      const double mean_ke = sim_.bodies().size() ? sim_.kinetic_energy_j() / sim_.bodies().size() : 0.0;
      below = mean_ke < p.ke_threshold_j ? below + 1 : 0;
      if (k + 1 >= p.min_steps && below >= p.hold_steps) {
        ++k;
        break;
      }
    }
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double rate = wall > 0.0 ? static_cast<double>(sim_.spheres().size()) * static_cast<double>(k) / wall : 0.0;
  log_ << "phase '" << p.name << "' ends at t = " << sim_.time_s() << " s after " << k << " steps";
  log_ << "; wall " << wall << " s, " << rate << " sphere-steps/s, " << rate / omp_get_max_threads()
       << " sphere-steps/s/thread";
  if (p.criterion)
    log_ << (below >= p.hold_steps ? " (settled: mean kinetic energy below threshold)"
                                   : " (max_duration_s reached before the bed was at rest)");
  log_ << "\n";
  log_.flush();
}

RunSummary Runner::run() {
  if (opt_.resume)
    throw Error("--resume: checkpoint/restart is not implemented yet in this version");
  io::prepare_output_dir(opt_.out_dir);
  if (opt_.threads > 0) omp_set_num_threads(opt_.threads);
  fs::create_directories(opt_.out_dir + "/snapshots");
  log_.open(opt_.out_dir + "/run.log", std::ios::trunc);
  const double dt = cfg_.run.dt_s;
  sample_every_ = std::max<std::uint64_t>(1, steps_for(1.0 / cfg_.output.sample_hz, dt));
  if (cfg_.output.snapshot_every_s) snapshot_every_ = std::max<std::uint64_t>(1, steps_for(*cfg_.output.snapshot_every_s, dt));
  write_log_header();

  series_ = std::make_unique<SeriesOut>(opt_.out_dir + "/series.csv");
  if (cfg_.output.trace) {
    trace_ = std::make_unique<std::ofstream>(opt_.out_dir + "/trace.csv", std::ios::trunc);
    *trace_ << "time_s,body_id,x_m,y_m,z_m,vx_m_s,vy_m_s,vz_m_s,wx_rad_s,wy_rad_s,wz_rad_s\n";
  }
  pvd_ = std::make_unique<io::PvdCollection>(opt_.out_dir + "/snapshots.pvd");
  pvd_bodies_ = std::make_unique<io::PvdCollection>(opt_.out_dir + "/bodies.pvd");

  const auto phases = plan_phases(cfg_);
  total_steps_estimate_ = 1;
  for (const auto& p : phases) total_steps_estimate_ += p.max_steps;

  const auto t0 = std::chrono::steady_clock::now();
  insert_all();
  sim_.refresh();
  log_ << "bodies: " << sim_.bodies().size() << ", spheres: " << sim_.spheres().size() << "\n";
  total_steps_estimate_ += sim_.step_count();
  sample();
  snapshot();
  for (std::size_t i = 0; i < phases.size(); ++i) run_phase(phases[i], i);
  if (sim_.step_count() % sample_every_ != 0) sample();  // the series always ends at the final state
  if (!snapshot_every_ || sim_.step_count() % snapshot_every_ != 0) snapshot();
  series_->flush();
  if (trace_) trace_->flush();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  RunSummary r;
  r.steps = sim_.step_count();
  r.simulated_s = sim_.time_s();
  r.wall_s = wall;
  r.bodies = sim_.bodies().size();
  r.spheres = sim_.spheres().size();
  const double rate = wall > 0 ? static_cast<double>(r.spheres) * static_cast<double>(r.steps) / wall : 0.0;
  log_ << "finished: " << r.steps << " steps, " << r.simulated_s << " s simulated, wall " << wall << " s, "
       << rate << " sphere-steps/s (" << rate / omp_get_max_threads() << " per thread), neighbour builds "
       << sim_.neighbor_list().builds() << "\n";
  log_.flush();
  std::ostringstream msg;
  msg << "done: " << r.steps << " steps (" << r.simulated_s << " s simulated) in " << io::format_duration(wall)
      << "; outputs in " << opt_.out_dir << " (series.csv, snapshots.pvd, run.log)";
  progress_.finish(msg.str());
  return r;
}

}  // namespace

RunSummary run_case(const io::LoadedCase& loaded, const RunOptions& options) {
  Runner r(loaded, options);
  return r.run();
}

}  // namespace biodem::driver
