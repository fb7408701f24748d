#include "driver/run_driver.hpp"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fcntl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <optional>
#include <numbers>
#include <random>
#include <sstream>

#if BIODEM_HAVE_OPENCV
#include <opencv2/imgcodecs.hpp>
#endif

#include "analysis/centroid_angle.hpp"
#if BIODEM_HAVE_OPENCV
#include "analysis/free_surface.hpp"
#include "analysis/render_frame.hpp"
#endif
#include "io/checkpoint.hpp"
#include "io/series_csv.hpp"
#include "core/error.hpp"
#include "core/parallel.hpp"
#include "driver/build_simulation.hpp"
#include "gpu/device_engine.hpp"
#include "io/case_report.hpp"
#include "io/output_dir.hpp"
#include "io/progress.hpp"
#include "io/vtk_writer.hpp"
#include "scenario/bulk_measures.hpp"

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
  bool translational = false;            // criterion on translational kinetic energy only
  std::optional<std::size_t> move_wall;  // bulk tests: wall translated during the phase
  Vec3 move_velocity_m_s;
  bool move_by_fill_height = false;  // [heap] lift: by the fill height + margin (at most max_steps)
  double move_margin_m = 0.0;
};

/// CPU time of the whole process (all threads), user + system, in seconds.
double process_cpu_s() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

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
    q.move_wall = p.move_wall;
    q.translational = p.translational_criterion;
    q.move_velocity_m_s = {p.move_velocity_m_s[0], p.move_velocity_m_s[1], p.move_velocity_m_s[2]};
    q.move_by_fill_height = p.move_by_fill_height;
    q.move_margin_m = p.move_margin_m;
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

class Runner {
 public:
  Runner(const io::LoadedCase& loaded, const RunOptions& opt)
      : cfg_(loaded.config), warnings_(loaded.warnings), opt_(opt), built_(build_simulation(cfg_)), sim_(*built_.sim),
        progress_(std::cerr, opt.progress_tty) {
    device_ = opt.device.value_or(cfg_.run.device);
    // Created before any output is touched: a GPU run without a GPU (or without the CUDA build)
    // stops here with one line.
    if (device_ == config::Device::Gpu) dev_ = gpu::make_device_engine(gpu::Backend::Cuda, sim_);
    if (device_ == config::Device::GpuEmulated) dev_ = gpu::make_device_engine(gpu::Backend::HostThreads, sim_);
    if (dev_ && cfg_.run.remove_lost_particles)
      throw Error(cfg_.source_path + ": [run] lost_particles = \"remove\" is not supported by the GPU engine (use --device cpu, or \"stop\")");
    if (dev_ && cfg_.bulk_test)
      throw Error(cfg_.source_path + ": the bulk tests ([heap], [bulk_density], [shear_box]) run on the CPU engine only (--device cpu)");
#if !BIODEM_HAVE_OPENCV
    if (cfg_.output.frame_every_s)
      throw Error(cfg_.source_path + ": [output] frame_every_s: back-lit frames are not built in this lean build (no OpenCV)");
#endif
  }

  RunSummary run();

 private:
  void write_log_header();
  /// Insertion in waves into the drum or a region, from the start or, after --resume, from the
  /// checkpoint's insertion state; then the state after insertion is made current and sampled.
  void insert();
  void finish_insertion();
  void write_responses();
  void run_phase(const PhasePlan& p, std::size_t index, std::uint64_t start_step, std::uint64_t below);
  void frame();
  void checkpoint();
  void resume();
  void after_step();
  void sample();
  void snapshot();
  double revolution() const;
  void report_progress(const std::string& label);
  [[noreturn]] void stop_on_signal();
  /// One time step on the selected engine.
  void advance();
  /// GPU engine: brings the host Simulation up to date (with the contact history when `history`).
  void sync(bool history);
  double kinetic_energy_j();
  double translational_kinetic_energy_j();

  const config::CaseConfig& cfg_;
  std::vector<std::string> warnings_;
  RunOptions opt_;
  BuiltCase built_;
  sim::Simulation& sim_;
  io::Progress progress_;
  std::unique_ptr<io::SeriesWriter> series_;
  std::unique_ptr<std::ofstream> trace_;
  std::unique_ptr<io::PvdCollection> pvd_, pvd_bodies_;
  std::ofstream log_;
  std::uint64_t sample_every_ = 1, snapshot_every_ = 0, frame_every_ = 0, checkpoint_every_ = 0;
  std::size_t frame_index_ = 0;
  std::uint64_t last_sample_step_ = ~std::uint64_t{0}, last_snapshot_step_ = ~std::uint64_t{0};
#if BIODEM_HAVE_OPENCV
  analysis::SurfaceParams surface_params_{};
#endif
  std::uint64_t case_hash_ = 0;
  // Where the run is, for checkpoints.
  std::size_t phase_index_ = 0;
  std::uint64_t phase_step_ = 0, settle_counter_ = 0;
  io::RunProgress resumed_;
  bool resumed_run_ = false;
  std::uint64_t total_steps_estimate_ = 1;
  double rotation_time_s_ = 0.0;
  std::size_t snapshot_index_ = 0;
  std::string current_phase_ = "insert";
  config::Device device_ = config::Device::Cpu;
  std::unique_ptr<gpu::DeviceEngine> dev_;
  std::uint64_t synced_step_ = ~std::uint64_t{0};
  bool synced_history_ = false;
  bool device_current_ = false;  // the device holds the run's state (host may lag behind)
  bool last_settled_ = false;
  io::InsertionProgress insertion_;  // while inserting: what a checkpoint must carry
};

void Runner::advance() {
  if (!dev_) {
    sim_.step();
    return;
  }
  dev_->step();
  device_current_ = true;
}

void Runner::sync(bool history) {
  if (!dev_ || !device_current_) return;
  if (synced_step_ == sim_.step_count() && (synced_history_ || !history)) return;
  dev_->download(history);
  synced_step_ = sim_.step_count();
  synced_history_ = history;
}

double Runner::kinetic_energy_j() { return dev_ && device_current_ ? dev_->kinetic_energy_j() : sim_.kinetic_energy_j(); }
double Runner::translational_kinetic_energy_j() {
  return dev_ && device_current_ ? dev_->translational_kinetic_energy_j() : sim_.translational_kinetic_energy_j();
}

double Runner::revolution() const {
  const double rpm = cfg_.drum ? std::abs(cfg_.drum->rpm) : 0.0;
  return rotation_time_s_ * rpm / 60.0;
}

void Runner::write_log_header() {
  log_ << "biodem run\ncase: " << cfg_.source_path << "\nthreads: " << omp_get_max_threads() << "\n";
  log_ << "engine: " << (dev_ ? "GPU engine on " + dev_->device_name() : std::string("CPU engine")) << "\n";
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
  if (last_sample_step_ == sim_.step_count()) return;  // already sampled at this step
  last_sample_step_ = sim_.step_count();
  sync(false);
  if (dev_ && device_current_) sim_.check_lost_bodies();  // the GPU engine: checked at every sample ("stop" only)
  const auto& b = sim_.bodies();
  double m = 0.0, xc = 0.0, yc = 0.0;
  for (std::size_t i = 0; i < b.size(); ++i) {
    m += b.mass_kg[i];
    xc += b.mass_kg[i] * b.position_m[i].x;
    yc += b.mass_kg[i] * b.position_m[i].y;
  }
  io::SeriesRow row;
  row.time_s = sim_.time_s();
  row.revolution = revolution();
  const bool clockwise = cfg_.drum && cfg_.drum->rpm < 0.0;  // alpha rises with the bed for either direction
  row.alpha_deg =
      m > 0.0 ? analysis::centroid_angle_deg(xc / m, yc / m, clockwise) : std::numeric_limits<double>::quiet_NaN();
#if BIODEM_HAVE_OPENCV  // the free surface is measured on the rendered cross-section (none in the lean build)
  if (built_.drum && sim_.spheres().size() > 0) {
    const auto& s = sim_.spheres();
    std::vector<double> x(s.size()), y(s.size());
    for (std::size_t i = 0; i < s.size(); ++i) {
      x[i] = s.position_m[i].x;
      y[i] = s.position_m[i].y;
    }
    const auto fit = analysis::fit_free_surface(x, y, s.radius_m, built_.drum->radius_m(), surface_params_);
    if (fit.valid) {
      row.surface_r2 = fit.r2;
      row.surface_angle_deg = fit.angle_deg;
    }
  }
#endif
  row.kinetic_energy_j = sim_.kinetic_energy_j();
  row.contacts = static_cast<std::int64_t>(sim_.contact_count());
  row.lost_bodies = static_cast<std::int64_t>(sim_.lost_bodies());
  series_->write(row);
  if (trace_) {
    char buf[512];
    // Rows in id order; ids are stable and have gaps once a sink removed bodies.
    std::vector<std::pair<std::uint32_t, std::uint32_t>> by_id(b.size());
    for (std::size_t i = 0; i < b.size(); ++i) by_id[i] = {b.id[i], static_cast<std::uint32_t>(i)};
    std::sort(by_id.begin(), by_id.end());
    for (const auto& [id32, i32] : by_id) {
      const std::size_t id = id32, i = i32;
      const Vec3 &x = b.position_m[i], &v = b.velocity_m_s[i], &w = b.angular_velocity_rad_s[i];
      std::snprintf(buf, sizeof buf, "%.9g,%zu,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", sim_.time_s(), id, x.x,
                    x.y, x.z, v.x, v.y, v.z, w.x, w.y, w.z);
      *trace_ << buf;
    }
  }
}

void Runner::snapshot() {
  last_snapshot_step_ = sim_.step_count();
  sync(false);
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

/// SIGINT / SIGTERM: the handler only records the signal; the run finishes its step, writes a
/// checkpoint and stops (after_step).
volatile std::sig_atomic_t g_stop_signal = 0;
extern "C" void on_stop_signal(int sig) { g_stop_signal = sig; }

/// Test hook: BIODEM_TEST_SIGNAL_AT_STEP=N raises SIGTERM in the process once step N is done, so
/// that the signal test stops the run at a chosen step.
std::uint64_t signal_at_step() {
  static const std::uint64_t n = [] {
    const char* v = std::getenv("BIODEM_TEST_SIGNAL_AT_STEP");
    return v ? std::strtoull(v, nullptr, 10) : 0ull;
  }();
  return n;
}

/// Test hook: BIODEM_TEST_ABORT_AT_STEP=N ends the process abruptly (no flush, no destructors,
/// exit status 137 as after SIGKILL) once step N is done and its outputs are written, so that
/// the kill-and-resume tests stop a run at a chosen step instead of racing a timer.
std::uint64_t abort_at_step() {
  static const std::uint64_t n = [] {
    const char* v = std::getenv("BIODEM_TEST_ABORT_AT_STEP");
    return v ? std::strtoull(v, nullptr, 10) : 0ull;
  }();
  return n;
}

void Runner::after_step() {
  if (sim_.drum_rotating()) rotation_time_s_ += sim_.dt_s();
  const std::uint64_t n = sim_.step_count();
  if (n % sample_every_ == 0) sample();
  if (snapshot_every_ && n % snapshot_every_ == 0) snapshot();
  if (frame_every_ && n % frame_every_ == 0) frame();
  if (checkpoint_every_ && n % checkpoint_every_ == 0) checkpoint();
  if ((n & 63) == 0) report_progress(current_phase_);
  if (abort_at_step() && n == abort_at_step()) std::_Exit(137);
  if (signal_at_step() && n == signal_at_step()) std::raise(SIGTERM);
  if (g_stop_signal) stop_on_signal();
}

void Runner::stop_on_signal() {
  const int sig = g_stop_signal;
  const char* name = sig == SIGINT ? "SIGINT" : (sig == SIGTERM ? "SIGTERM" : "a signal");
  std::ostringstream msg;
  msg << "interrupted by " << name << " at t = " << sim_.time_s() << " s (step " << sim_.step_count() << ")";
  if (insertion_.active) msg << " while inserting particles (" << insertion_.placed << " placed)";
  checkpoint();
  msg << ": checkpoint written to " << opt_.out_dir << "/checkpoint.bin; continue with --resume";
  log_ << msg.str() << "\n";
  log_.flush();
  throw Interrupted(sig, msg.str());
}

void Runner::frame() {
#if BIODEM_HAVE_OPENCV
  if (!built_.drum) return;
  sync(false);
  const auto& s = sim_.spheres();
  std::vector<double> x(s.size()), y(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    x[i] = s.position_m[i].x;
    y[i] = s.position_m[i].y;
  }
  const cv::Mat img = analysis::render_backlit_frame(x, y, s.radius_m, built_.drum->radius_m(),
                                                     static_cast<int>(cfg_.output.frame_size_px));
  char name[64];
  std::snprintf(name, sizeof name, "%06zu.png", frame_index_++);
  const std::string path = opt_.out_dir + "/frames/" + name;
  if (!cv::imwrite(path, img)) throw Error(path + ": cannot write frame");
#endif
}

/// Durably on disk (fsync): the appended outputs before a checkpoint records their sizes, and the
/// folder after the checkpoint's rename (a crash must not leave a checkpoint that counts rows the
/// disk never received, or lose the renamed checkpoint).
void fsync_path(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

/// Truncates an appended output back to what the checkpoint counted. A file shorter than that
/// lost rows the checkpoint relies on (extending it would pad with NUL bytes): an error.
void truncate_to_checkpoint(const std::string& path, std::uint64_t bytes) {
  const auto size = fs::file_size(path);
  if (size < bytes)
    throw Error("--resume: " + path + " has " + std::to_string(size) + " bytes, fewer than the " + std::to_string(bytes) +
                " the checkpoint recorded (rows were lost); start the run again");
  fs::resize_file(path, bytes);
}

void Runner::checkpoint() {
  sync(true);
  series_->flush();
  if (trace_) trace_->flush();
  fsync_path(opt_.out_dir + "/series.csv");
  if (trace_) fsync_path(opt_.out_dir + "/trace.csv");
  io::RunProgress rp;
  rp.case_hash = case_hash_;
  rp.phase_index = phase_index_;
  rp.phase_step = phase_step_;
  rp.settle_counter = settle_counter_;
  rp.rotation_time_s = rotation_time_s_;
  rp.snapshot_index = snapshot_index_;
  rp.series_bytes = fs::file_size(opt_.out_dir + "/series.csv");
  rp.trace_bytes = trace_ ? fs::file_size(opt_.out_dir + "/trace.csv") : 0;
  rp.pvd_spheres = pvd_->entries();
  rp.pvd_bodies = pvd_bodies_->entries();
  rp.last_sample_step = last_sample_step_;
  rp.last_snapshot_step = last_snapshot_step_;
  rp.last_settled = last_settled_;
  rp.insertion = insertion_;
  // frame index is implied by the step count
  io::save_checkpoint(opt_.out_dir + "/checkpoint.bin", sim_, rp);
  fsync_path(opt_.out_dir);
}

void Runner::resume() {
  const std::string path = opt_.out_dir + "/checkpoint.bin";
  resumed_ = io::load_checkpoint(path, sim_);
  if (dev_) {
    dev_->upload();  // the checkpoint's forces and contact history: the run continues as it was
    device_current_ = true;
    synced_step_ = sim_.step_count();
    synced_history_ = true;
  }
  if (resumed_.case_hash != case_hash_)
    throw Error("--resume: " + path + " was written for a different case file than " + cfg_.source_path);
  rotation_time_s_ = resumed_.rotation_time_s;
  snapshot_index_ = resumed_.snapshot_index;
  frame_index_ = frame_every_ ? sim_.step_count() / frame_every_ : 0;
  truncate_to_checkpoint(opt_.out_dir + "/series.csv", resumed_.series_bytes);
  if (cfg_.output.trace) truncate_to_checkpoint(opt_.out_dir + "/trace.csv", resumed_.trace_bytes);
  resumed_run_ = true;
  if (resumed_.version >= 5) {
    last_sample_step_ = resumed_.last_sample_step;
    last_snapshot_step_ = resumed_.last_snapshot_step;
    last_settled_ = resumed_.last_settled;
    insertion_ = resumed_.insertion;
  } else {
    // Version 4 (never written during insertion): a checkpoint is taken after the step's sample
    // and snapshot: do not repeat them.
    last_sample_step_ = sim_.step_count();
    last_snapshot_step_ = snapshot_every_ && sim_.step_count() % snapshot_every_ == 0 ? sim_.step_count()
                                                                                        : last_snapshot_step_;
  }
}

// Insertion in waves (SPEC 5; regions: issue 9): each wave places what fits into the drum or
// the region, then the particles fall for wave_fall_s (default: the free fall over the drum
// diameter, the box diagonal or the cylinder height) before the next wave; mode = "pack" places
// all in one wave. Three waves in a row that place nothing stop the run. Checkpoints may be taken
// during the falls: insertion_ holds what a resumed run needs to go on (issue 10, item 5).
void Runner::insert() {
  if (!cfg_.insertion || built_.populations.empty() ||
      (cfg_.insertion->region == config::Insertion::Region::Drum && !built_.drum)) {
    insertion_ = io::InsertionProgress{};  // nothing to insert
    return;
  }
  const auto& ins = *cfg_.insertion;
  const bool drum = ins.region == config::Insertion::Region::Drum;
  const std::uint64_t count = io::implied_particle_count(cfg_);
  std::mt19937_64 rng(cfg_.run.seed);
  // The order of the bodies: drawn from the seed again on resume (the generator then continues
  // from the checkpoint's state).
  const auto todo = scenario::plan_population(count, built_.population_volume_fraction,
                                              built_.population_particle_volume_m3, built_.populations, rng);
  const auto v3 = [](const config::Vec3d& a) { return Vec3{a[0], a[1], a[2]}; };
  scenario::CylinderRegion drum_region;
  scenario::Region region;
  double fall_height_m = 0.0;
  if (drum) {
    drum_region.radius_m = built_.drum->radius_m();
    drum_region.z_min_m = 0.0;
    drum_region.z_max_m = built_.drum->width_m;
    drum_region.periodic_z = built_.drum->periodic_axis;
    fall_height_m = built_.drum->diameter_m;
  } else if (ins.region == config::Insertion::Region::Box) {
    region.kind = scenario::Region::Kind::Box;
    region.min_m = v3(ins.region_min_m);
    region.max_m = v3(ins.region_max_m);
    fall_height_m = norm(region.max_m - region.min_m);
  } else {
    region.kind = scenario::Region::Kind::Cylinder;
    region.base_m = v3(ins.region_base_m);
    region.axis = normalized(v3(ins.region_axis));
    region.radius_m = ins.region_radius_m;
    region.height_m = ins.region_height_m;
    fall_height_m = ins.region_height_m;
  }
  const std::string into = drum ? "into the drum" : "into the region";
  const auto& gv = cfg_.run.gravity_m_s2;
  const double g = std::max(1e-6, std::sqrt(gv[0] * gv[0] + gv[1] * gv[1] + gv[2] * gv[2]));
  const double fall_s = ins.wave_fall_s.value_or(std::sqrt(2.0 * fall_height_m / g));
  const std::uint64_t fall_steps = std::max<std::uint64_t>(1, steps_for(fall_s, cfg_.run.dt_s));
  const bool pack = !drum && ins.mode == config::Insertion::Mode::Pack;

  bool falling = false;  // a resumed run may be in the middle of a fall
  if (resumed_run_ && insertion_.active) {
    if (insertion_.placed > todo.size() || insertion_.fall_step > fall_steps)
      throw Error("--resume: " + opt_.out_dir + "/checkpoint.bin: the insertion state does not match this case");
    falling = true;
    log_ << "insertion resumes at t = " << sim_.time_s() << " s after wave " << insertion_.waves << " ("
         << insertion_.placed << " of " << todo.size() << " particles placed)\n";
  } else {
    insertion_ = io::InsertionProgress{};
    insertion_.active = true;
    insertion_.rng = rng;
  }
  current_phase_ = "insert";
  for (;;) {
    if (falling) {
      while (insertion_.fall_step < fall_steps) {
        advance();
        ++insertion_.fall_step;
        after_step();
      }
      falling = false;
    }
    if (insertion_.placed >= todo.size()) break;
    const std::size_t before = insertion_.placed;
    sync(true);  // GPU engine: the host inserts into the current state, contact history included
    insertion_.placed =
        drum ? scenario::insert_wave(sim_, drum_region, todo, before, ins.max_attempts_per_particle, insertion_.rng)
             : scenario::insert_wave(sim_, region, todo, before, ins.max_attempts_per_particle, insertion_.rng);
    const std::size_t placed = insertion_.placed;
    ++insertion_.waves;
    log_ << "insertion wave " << insertion_.waves << " at t = " << sim_.time_s() << " s: " << (placed - before)
         << " particles (total " << placed << " of " << todo.size() << ")\n";
    log_.flush();
    if (pack && placed < todo.size())
      throw Error("[insertion] count = " + std::to_string(todo.size()) + ": only " + std::to_string(placed) +
                  " particles could be packed into the region (mode = \"pack\" places them in one wave; use " +
                  "\"pour\" or a larger region)");
    if (placed == before) {
      if (++insertion_.empty_waves >= 3)
        throw Error("[insertion] count = " + std::to_string(todo.size()) + ": only " + std::to_string(placed) +
                    " particles could be inserted " + into + " (three insertion waves in a row placed none)");
    } else {
      insertion_.empty_waves = 0;
    }
    if (placed < todo.size()) {
      if (dev_) {
        dev_->upload();
        device_current_ = true;
        synced_step_ = ~std::uint64_t{0};
      }
      insertion_.fall_step = 0;
      falling = true;
    }
  }
  insertion_ = io::InsertionProgress{};  // done: later checkpoints carry no insertion state
}

void Runner::finish_insertion() {
  if (dev_) {
    // Forces of the inserted state on the device (contact history kept), then the host made
    // current for the first sample, snapshot and checkpoint.
    dev_->upload();
    device_current_ = true;
    synced_step_ = ~std::uint64_t{0};
    sync(true);
  } else {
    sim_.refresh();
  }
  log_ << "bodies: " << sim_.bodies().size() << ", spheres: " << sim_.spheres().size() << "\n";
  total_steps_estimate_ += sim_.step_count();
  sample();
  snapshot();
  if (checkpoint_every_) checkpoint();  // resumable from the end of insertion on
}

// Responses of a bulk test (SPEC 7, 11), measured on the final state: docs/calibration.md.
void Runner::write_responses() {
  const auto& b = *cfg_.bulk_test;
  const auto& s = sim_.spheres();
  const auto& bd = sim_.bodies();
  struct Row {
    std::string name;
    double value;
    std::string unit;
  };
  std::vector<Row> rows;
  double d = 0.0;  // profile bin: the largest volume-equivalent diameter of the poured shapes
  for (const auto& p : built_.populations) d = std::max(d, sim_.templates()[p.shape].equivalent_diameter_m());
  if (b.kind == config::BulkTest::Kind::Heap) {
    scenario::HeapOptions o;
    o.bin_m = d;
    o.sectors = b.sectors;
    o.fit_from = b.fit_from_fraction;
    o.fit_to = b.fit_to_fraction;
    const auto h = scenario::measure_heap(s.position_m, s.radius_m, s.body, {0, 0, 0}, {0, 1, 0}, o);
    rows.push_back({"angle_of_repose_deg", h.angle_deg, "deg"});
    rows.push_back({"angle_of_repose_spread_deg", h.angle_spread_deg, "deg"});
    rows.push_back({"angle_of_repose_min_deg", h.angle_min_deg, "deg"});
    rows.push_back({"angle_of_repose_max_deg", h.angle_max_deg, "deg"});
    rows.push_back({"heap_sectors_fitted", static_cast<double>(h.sectors_fitted), "-"});
    rows.push_back({"heap_height_m", h.height_m, "m"});
    rows.push_back({"heap_base_radius_m", h.base_radius_m, "m"});
    rows.push_back({"heap_bodies", static_cast<double>(h.heap_bodies), "-"});
    rows.push_back({"stray_bodies", static_cast<double>(h.stray_bodies), "-"});
    rows.push_back({"heap_found", h.valid ? 1.0 : 0.0, "-"});
  } else if (b.kind == config::BulkTest::Kind::BulkDensity) {
    const double R = 0.5 * b.container_diameter_m, H = b.container_height_m;
    double m = 0.0, v = 0.0, y_max = -1e300, v_core = 0.0;
    const double rc = R - d;  // core: one particle size away from the wall, the bottom and the rim
    for (std::size_t i = 0; i < bd.size(); ++i) {
      const Vec3 x = bd.position_m[i];
      y_max = std::max(y_max, x.y);
      if (x.y > d && x.y < H - d && x.x * x.x + x.z * x.z < rc * rc) v_core += sim_.templates()[bd.shape[i]].volume_m3;
      if (x.y > H || x.x * x.x + x.z * x.z > R * R || x.y < 0.0) continue;  // struck off, or outside
      m += bd.mass_kg[i];
      v += sim_.templates()[bd.shape[i]].volume_m3;
    }
    if (!(y_max > H))
      throw Error("[insertion].count = " + std::to_string(bd.size() + sim_.removed_bodies()) +
                  ": the container did not overflow (highest body centre at " + std::to_string(y_max) +
                  " m, rim at " + std::to_string(H) + " m); pour more particles");
    const double volume = std::numbers::pi * R * R * H;
    rows.push_back({"bulk_density_kg_m3", m / volume, "kg/m3"});
    rows.push_back({"solid_fraction", v / volume, "-"});
    rows.push_back({"mass_in_container_kg", m, "kg"});
    if (rc > 0.0 && H > 2.0 * d)
      rows.push_back({"core_solid_fraction", v_core / (std::numbers::pi * rc * rc * (H - 2.0 * d)), "-"});
  } else {
    double m_in = 0.0, m_all = sim_.removed_mass_kg();
    for (std::size_t i = 0; i < bd.size(); ++i) {
      m_all += bd.mass_kg[i];
      if (bd.position_m[i].x < b.length_m) m_in += bd.mass_kg[i];
    }
    rows.push_back({"retainment_ratio", m_all > 0.0 ? m_in / m_all : 0.0, "-"});
    rows.push_back({"mass_retained_kg", m_in, "kg"});
    rows.push_back({"mass_poured_kg", m_all, "kg"});
  }
  rows.push_back({"at_rest", last_settled_ ? 1.0 : 0.0, "-"});
  const std::string path = opt_.out_dir + "/responses.csv";
  std::ofstream f(path, std::ios::trunc);
  f << "response,value,unit\n";
  char buf[64];
  for (const auto& r : rows) {
    std::snprintf(buf, sizeof buf, "%.9g", r.value);
    f << r.name << "," << buf << "," << r.unit << "\n";
  }
  if (!f) throw Error(path + ": cannot write");
  log_ << "responses (" << path << "):";
  for (const auto& r : rows) log_ << " " << r.name << " = " << r.value << " " << r.unit << ";";
  log_ << (last_settled_ ? "" : " WARNING: the scene was not at rest when measured (max_rest_s reached)") << "\n";
}

void Runner::run_phase(const PhasePlan& p, std::size_t index, std::uint64_t start_step, std::uint64_t below) {
  current_phase_ = p.name;
  phase_index_ = index;
  sim_.set_drum_rotation(p.rotate);
  if (dev_) dev_->sync_walls();
  log_ << "phase " << index + 1 << " '" << p.name << "' " << (start_step ? "resumes" : "starts") << " at t = "
       << sim_.time_s() << " s (step " << sim_.step_count() << "), rotation " << (p.rotate ? "on" : "off") << "\n";
  std::uint64_t k = start_step;
  std::uint64_t max_steps = p.max_steps;
  if (p.move_wall && start_step == 0) {
    if (p.move_by_fill_height) {
      // [heap]: lift by the settled fill's height plus the margin (SPEC 7), not the whole tube.
      double fill_top = 0.0;
      const auto& sp = sim_.spheres();
      for (std::size_t i = 0; i < sp.size(); ++i) fill_top = std::max(fill_top, sp.position_m[i].y + sp.radius_m[i]);
      const double speed = norm(p.move_velocity_m_s);
      const double full = static_cast<double>(p.max_steps) * sim_.dt_s() * speed;
      const double lift = std::min(full, fill_top + p.move_margin_m);
      max_steps = std::max<std::uint64_t>(1, steps_for(lift / speed, sim_.dt_s()));
      const double diameter = cfg_.bulk_test ? cfg_.bulk_test->cylinder_diameter_m : 0.0;
      log_ << "heap fill: height " << fill_top << " m = " << (diameter > 0.0 ? fill_top / diameter : 0.0)
           << " cylinder diameters; lift by " << lift << " m (fill + margin " << p.move_margin_m << " m"
           << (lift < fill_top + p.move_margin_m ? ", capped at the cylinder height" : "") << ")\n";
      if (diameter > 0.0 && (fill_top < 1.5 * diameter || fill_top > 2.5 * diameter))
        log_ << "WARNING: the fill stands " << fill_top / diameter
             << " cylinder diameters high; the heap procedure fills to about 2 (a full cone must fit): change [insertion] count\n";
    }
    const double t_end = sim_.time_s() + static_cast<double>(max_steps) * sim_.dt_s();
    sim_.start_wall_translation(*p.move_wall, p.move_velocity_m_s, sim_.time_s(), t_end);
    log_ << "wall " << *p.move_wall + 1 << " moves at (" << p.move_velocity_m_s.x << ", " << p.move_velocity_m_s.y
         << ", " << p.move_velocity_m_s.z << ") m/s until t = " << t_end << " s\n";
  } else if (p.move_wall && p.move_by_fill_height) {
    // Resumed during the lift: its length is the wall's schedule, which the checkpoint holds.
    const auto& w = sim_.walls()[*p.move_wall];
    max_steps = steps_for(w.move_end_s - w.move_start_s, sim_.dt_s());
  }
  log_.flush();  // a run killed during the phase still says which phase it was in
  sim_.set_profile(opt_.profile && !dev_);
  sim_.reset_profile();
  const double cpu0 = process_cpu_s();
  const auto t0 = std::chrono::steady_clock::now();
  bool settled = p.criterion && k >= p.min_steps && below >= p.hold_steps;
  while (!settled && k < max_steps) {
    advance();
    ++k;
    if (p.criterion) {
      const double ke = p.translational ? translational_kinetic_energy_j() : kinetic_energy_j();
      const double mean_ke = sim_.bodies().size() ? ke / sim_.bodies().size() : 0.0;
      below = mean_ke < p.ke_threshold_j ? below + 1 : 0;
      settled = k >= p.min_steps && below >= p.hold_steps;
    }
    phase_step_ = k;
    settle_counter_ = below;
    after_step();
  }
  k -= start_step;
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double rate = wall > 0.0 ? static_cast<double>(sim_.spheres().size()) * static_cast<double>(k) / wall : 0.0;
  log_ << "phase '" << p.name << "' ends at t = " << sim_.time_s() << " s after " << k << " steps";
  log_ << "; wall " << wall << " s, " << (k ? 1e6 * wall / static_cast<double>(k) : 0.0) << " us/step, " << rate
       << " sphere-steps/s";
  if (!dev_) {
    log_ << ", " << rate / omp_get_max_threads() << " sphere-steps/s/thread";
    // Did the host give every thread a core? Process CPU time over wall time (the step's
    // workers spin between jobs, so a thread that holds a core counts fully): measured, so that
    // timings taken on a busy host say so (issue 18).
    // Scenes below the parallel threshold step on one thread while the others sleep.
    const double cores = wall > 0.0 ? (process_cpu_s() - cpu0) / wall : 0.0;
    const int threads = sim_.spheres().size() >= kParallelThreshold ? omp_get_max_threads() : 1;
    char buf[160];
    std::snprintf(buf, sizeof buf, "; CPU %.2f cores for %d stepping thread%s", cores, threads, threads == 1 ? "" : "s");
    log_ << buf;
    if (wall > 1.0 && cores < 0.85 * threads)
      log_ << " (WARNING: the host gave this run only " << cores << " of " << threads
           << " cores: other load; the timing understates the speed)";
  }
  if (opt_.profile && !dev_ && sim_.profile().steps > 0) {
    const sim::StepProfile& q = sim_.profile();
    const double per = 1e6 / static_cast<double>(q.steps);
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "\nprofile '%s' (us/step over %llu steps, %llu list builds): step %.1f = drift %.1f + list %.1f + "
                  "pairs %.1f (threads busy %.0f %%) + gather/walls/kick %.1f; outside step() %.1f",
                  p.name.c_str(), static_cast<unsigned long long>(q.steps), static_cast<unsigned long long>(q.builds),
                  q.step_s * per, q.drift_s * per, q.list_s * per, q.pairs_s * per,
                  q.pairs_s > 0.0 ? 100.0 * q.pairs_busy_s / q.pairs_s : 0.0, q.gather_s * per,
                  (wall - q.step_s) * per);
    log_ << buf;
  }
  if (p.criterion) last_settled_ = below >= p.hold_steps;
  if (p.criterion)
    log_ << (below >= p.hold_steps ? " (settled: mean kinetic energy below threshold)"
                                   : " (max_duration_s reached before the bed was at rest)");
  log_ << "\n";
  log_.flush();
}

RunSummary Runner::run() {
  if (opt_.resume) {
    if (!fs::exists(opt_.out_dir + "/checkpoint.bin"))
      throw Error("--resume: " + opt_.out_dir + "/checkpoint.bin does not exist (nothing to resume)");
  } else {
    io::prepare_output_dir(opt_.out_dir);
    // A fresh run replaces the outputs of an earlier run in the same folder: an old checkpoint must
    // never be resumed, and stale snapshots, frames or trace would be mistaken for this run's.
    fs::remove(opt_.out_dir + "/checkpoint.bin");
    fs::remove(opt_.out_dir + "/trace.csv");
    fs::remove(opt_.out_dir + "/responses.csv");
    fs::remove_all(opt_.out_dir + "/snapshots");
    fs::remove_all(opt_.out_dir + "/frames");
  }
  if (opt_.threads > 0) omp_set_num_threads(opt_.threads);
  fs::create_directories(opt_.out_dir + "/snapshots");
  if (cfg_.output.frame_every_s) fs::create_directories(opt_.out_dir + "/frames");
  {
    std::ifstream in(cfg_.source_path, std::ios::binary);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    case_hash_ = io::fnv1a(text.data(), text.size());
  }
  const double dt = cfg_.run.dt_s;
  sample_every_ = std::max<std::uint64_t>(1, steps_for(1.0 / cfg_.output.sample_hz, dt));
  if (cfg_.output.snapshot_every_s) snapshot_every_ = std::max<std::uint64_t>(1, steps_for(*cfg_.output.snapshot_every_s, dt));
  if (cfg_.output.frame_every_s) frame_every_ = std::max<std::uint64_t>(1, steps_for(*cfg_.output.frame_every_s, dt));
  if (cfg_.output.checkpoint_every_s)
    checkpoint_every_ = std::max<std::uint64_t>(1, steps_for(*cfg_.output.checkpoint_every_s, dt));
  // The free surface is measured on the cross-section rendered as the run's frames (one method
  // for runs and videos, docs/analysis.md section 4).
#if BIODEM_HAVE_OPENCV
  surface_params_ = analysis::SurfaceParams::for_frames(static_cast<int>(cfg_.output.frame_size_px));
  surface_params_.image.mirror_x = cfg_.drum && cfg_.drum->rpm < 0.0;  // as `biodem video --rotation cw`
#endif

  const auto phases = plan_phases(cfg_);
  total_steps_estimate_ = 1;
  for (const auto& p : phases) total_steps_estimate_ += p.max_steps;

  const auto t0 = std::chrono::steady_clock::now();
  std::size_t first_phase = 0;
  std::uint64_t first_step = 0, first_below = 0;
  if (opt_.resume) {
    resume();
    log_.open(opt_.out_dir + "/run.log", std::ios::app);
    log_ << "\nresumed from checkpoint.bin at t = " << sim_.time_s() << " s (step " << sim_.step_count() << ")\n";
    series_ = std::make_unique<io::SeriesWriter>(opt_.out_dir + "/series.csv", true);
    if (cfg_.output.trace) trace_ = std::make_unique<std::ofstream>(opt_.out_dir + "/trace.csv", std::ios::app);
    pvd_ = std::make_unique<io::PvdCollection>(opt_.out_dir + "/snapshots.pvd");
    pvd_bodies_ = std::make_unique<io::PvdCollection>(opt_.out_dir + "/bodies.pvd");
    pvd_->set_entries(resumed_.pvd_spheres);
    pvd_bodies_->set_entries(resumed_.pvd_bodies);
    first_phase = resumed_.phase_index;
    if (first_phase >= phases.size()) last_snapshot_step_ = sim_.step_count();  // the run had finished
    first_step = resumed_.phase_step;
    first_below = resumed_.settle_counter;
    phase_index_ = first_phase;
    phase_step_ = first_step;
    settle_counter_ = first_below;
    if (!insertion_.active) total_steps_estimate_ += sim_.step_count();  // else: at the end of insertion
  } else {
    log_.open(opt_.out_dir + "/run.log", std::ios::trunc);
    write_log_header();
    series_ = std::make_unique<io::SeriesWriter>(opt_.out_dir + "/series.csv", false);
    if (cfg_.output.trace) {
      trace_ = std::make_unique<std::ofstream>(opt_.out_dir + "/trace.csv", std::ios::trunc);
      *trace_ << "time_s,body_id,x_m,y_m,z_m,vx_m_s,vy_m_s,vz_m_s,wx_rad_s,wy_rad_s,wz_rad_s\n";
    }
    pvd_ = std::make_unique<io::PvdCollection>(opt_.out_dir + "/snapshots.pvd");
    pvd_bodies_ = std::make_unique<io::PvdCollection>(opt_.out_dir + "/bodies.pvd");
  }
  if (!opt_.resume || insertion_.active) {  // a fresh run, or one killed while inserting
    insert();
    finish_insertion();
  }
  const std::uint64_t steps_at_start = sim_.step_count();
  for (std::size_t i = first_phase; i < phases.size(); ++i) {
    run_phase(phases[i], i, i == first_phase ? first_step : 0, i == first_phase ? first_below : 0);
    phase_step_ = 0;
    settle_counter_ = 0;
  }
  sync(true);
  if (cfg_.bulk_test) write_responses();
  if (sim_.step_count() % sample_every_ != 0) sample();  // the series always ends at the final state
  if (last_snapshot_step_ != sim_.step_count()) snapshot();
  phase_index_ = phases.size();
  phase_step_ = 0;
  if (checkpoint_every_) checkpoint();  // the final state: a later --resume finds nothing left to do
  series_->flush();
  if (trace_) trace_->flush();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  RunSummary r;
  r.steps = sim_.step_count();
  r.simulated_s = sim_.time_s();
  r.wall_s = wall;
  r.bodies = sim_.bodies().size();
  r.spheres = sim_.spheres().size();
  const double done = static_cast<double>(r.steps - steps_at_start);
  const double rate = wall > 0 ? static_cast<double>(r.spheres) * done / wall : 0.0;
  if (!sim_.sinks().empty())
    log_ << "sinks removed " << sim_.removed_bodies() << " bodies, " << sim_.removed_mass_kg() << " kg\n";
  if (sim_.lost_bodies())
    log_ << "lost bodies removed (left the drum or the [run] bounds box): " << sim_.lost_bodies() << "\n";
  log_ << "finished: " << r.steps << " steps, " << r.simulated_s << " s simulated, wall " << wall << " s, "
       << rate << " sphere-steps/s";
  if (dev_)
    log_ << ", " << (done > 0 ? 1e6 * wall / done : 0.0) << " us/step on " << dev_->device_name()
         << ", device neighbour builds " << dev_->list_builds() << ", row widenings " << dev_->row_widenings()
         << " (row capacity " << dev_->row_capacity() << ")\n";
  else
    log_ << " (" << rate / omp_get_max_threads() << " per thread), neighbour builds " << sim_.neighbor_list().builds()
         << "\n";
  log_.flush();
  std::ostringstream msg;
  msg << "done: " << r.steps << " steps (" << r.simulated_s << " s simulated) in " << io::format_duration(wall)
      << "; outputs in " << opt_.out_dir << " (series.csv, snapshots.pvd, run.log)";
  progress_.finish(msg.str());
  return r;
}

}  // namespace

RunSummary run_case(const io::LoadedCase& loaded, const RunOptions& options) {
  // Test hook: BIODEM_TEST_PARALLEL_THRESHOLD=N runs every loop over at least N items on the
  // threads (0: all of them, so that small test scenes exercise the parallel paths, e.g. the GPU
  // engine's kernels on CPU threads in scripts/gpu_check.sh).
  if (const char* v = std::getenv("BIODEM_TEST_PARALLEL_THRESHOLD")) set_parallel_threshold(std::strtoull(v, nullptr, 10));
  Runner r(loaded, options);
  // SIGINT / SIGTERM stop the run at the end of the current step with a checkpoint.
  struct Handlers {
    void (*old_int)(int), (*old_term)(int);
    Handlers() : old_int(std::signal(SIGINT, on_stop_signal)), old_term(std::signal(SIGTERM, on_stop_signal)) {
      g_stop_signal = 0;
    }
    ~Handlers() {
      std::signal(SIGINT, old_int);
      std::signal(SIGTERM, old_term);
    }
  } handlers;
  return r.run();
}

}  // namespace biodem::driver
