// The run from start to end (Runner::run): output folder, run.log header, insertion, phases,
// final sample, snapshot, responses and checkpoint; engine access (CPU engine, or the GPU
// engine with the host copy synchronised on demand); SIGINT / SIGTERM and the test hooks.
// The other jobs of a run: runner.hpp lists their files.
#include "driver/run_driver.hpp"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "case_file/derived_quantities.hpp"
#include "core/error.hpp"
#include "core/parallel.hpp"
#include "driver/runner.hpp"
#include "output/analysis_files.hpp"
#include "output/build_info.hpp"
#include "output/case_report.hpp"
#include "output/output_dir.hpp"
#if BIODEM_HAVE_OPENCV
#include "analysis/render_frame.hpp"
#endif

namespace biodem::driver {
namespace {

namespace fs = std::filesystem;

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


}  // namespace

Runner::Runner(const case_file::LoadedCase& loaded, const RunOptions& opt)
    : cfg_(loaded.config), warnings_(loaded.warnings), opt_(opt), built_(build_simulation(cfg_)), sim_(*built_.sim),
      progress_(std::cerr, opt.progress_tty) {
  device_ = opt.device.value_or(cfg_.run.device);
  // Created before any output is touched: a GPU run without a GPU (or without the CUDA build)
  // stops here with one line.
  // A device asked for by the case, not the command line, is named as the case's key.
  auto make_engine = [&](gpu::Backend backend, const char* name) {
    try {
      return gpu::make_device_engine(backend, sim_);
    } catch (const Error& e) {
      const std::string what = e.what(), flag = "--device gpu: ";
      if (opt.device || what.rfind(flag, 0) != 0) throw;
      throw Error(cfg_.source_path + ": [run] device = \"" + name + "\": " + what.substr(flag.size()));
    }
  };
  if (device_ == config::Device::Gpu) dev_ = make_engine(gpu::Backend::Cuda, "gpu");
  if (device_ == config::Device::GpuEmulated) dev_ = make_engine(gpu::Backend::HostThreads, "gpu-emulated");
#if !BIODEM_HAVE_OPENCV
  if (cfg_.output.frame_every_s)
    throw Error(cfg_.source_path + ": [output] frame_every_s: back-lit frames are not built in this lean build (no OpenCV)");
  if (cfg_.output.speed_images.value_or(false))
    throw Error(cfg_.source_path + ": [output] speed_images: speed images are not built in this lean build (no OpenCV)");
#endif
}

void Runner::advance(bool next_follows) {
  // (the GPU engine steps through advance_on_device, in runs of steps)
  if (dev_) throw InternalError("internal: Runner::advance on the GPU engine");
  sim_.step(next_follows && !g_stop_signal);
}

/// Steps at most in one DeviceEngine::advance call: the progress bar and a signal wait at most
/// this long (milliseconds on a GPU).
constexpr std::uint64_t kDeviceRun = 200;

bool Runner::host_needs_state_at(std::uint64_t n) const {
  return n % sample_every_ == 0 || (snapshot_every_ && n % snapshot_every_ == 0) ||
         (frame_every_ && n % frame_every_ == 0) || (speed_image_every_ && n % speed_image_every_ == 0) ||
         (checkpoint_every_ && n % checkpoint_every_ == 0) ||
         (abort_at_step() && n == abort_at_step()) || (signal_at_step() && n == signal_at_step());
}

std::uint64_t Runner::device_run_length(std::uint64_t limit) const {
  const std::uint64_t m = std::min(limit, kDeviceRun);
  if (g_stop_signal) return std::min<std::uint64_t>(m, 1);
  const std::uint64_t n0 = sim_.step_count();
  for (std::uint64_t j = 1; j < m; ++j)
    if (host_needs_state_at(n0 + j)) return j;
  return m;
}

gpu::DeviceEngine::Advanced Runner::advance_on_device(
    std::uint64_t limit, const std::function<void(const gpu::DeviceEngine::Advanced&)>& each) {
  const std::uint64_t n0 = sim_.step_count();
  const double t0 = sim_.time_s();
  const gpu::DeviceEngine::Advanced a = dev_->advance(device_run_length(limit));
  device_current_ = true;
  // after_step for each step made, with the clock at that step (the same additions as a step at
  // a time); only the last one may use the state (device_run_length).
  sim_.set_step_count(n0);
  sim_.set_time_s(t0);
  for (std::uint64_t j = 1; j <= a.steps; ++j) {
    sim_.set_time_s(sim_.time_s() + sim_.dt_s());
    sim_.set_step_count(sim_.step_count() + 1);
    each(a);
    defer_stop_ = j < a.steps;
    after_step();
  }
  defer_stop_ = false;
  return a;
}

void Runner::remove_analysis_outputs() {
  // An earlier `biodem analyze` of the folder: its tables and plots describe the series.csv of
  // before (a fresh run's old one, or a resumed run's cut short at the checkpoint).
  output::remove_analysis_outputs(opt_.out_dir);
}

void Runner::sync(bool history) {
  if (!dev_ || !device_current_) return;
  if (synced_step_ == sim_.step_count() && (synced_history_ || !history)) return;
  dev_->download(history);
  synced_step_ = sim_.step_count();
  synced_history_ = history;
}

double Runner::kinetic_energy_j() { return dev_ && device_current_ ? dev_->kinetic_energy_j() : sim_.kinetic_energy_j(); }
std::uint64_t Runner::list_builds() const { return dev_ ? dev_->list_builds() : sim_.neighbor_list().builds(); }
double Runner::translational_kinetic_energy_j() {
  return dev_ && device_current_ ? dev_->translational_kinetic_energy_j() : sim_.translational_kinetic_energy_j();
}

double Runner::revolution() const {
  // Whole rotating steps times dt (rotation_time_s_ is their sum, with its rounding), as the
  // series gives the time.
  const double rpm = cfg_.drum ? std::abs(cfg_.drum->rpm) : 0.0;
  return config::whole_steps_time(rotation_time_s_, sim_.dt_s()) * rpm / 60.0;
}


void Runner::write_log_header() {
  log_ << "biodem run\ncase: " << cfg_.source_path << "\nbuild: " << output::build_description()
       << "\nthreads: " << omp_get_max_threads() << "\n";
  log_ << "engine: "
       << (dev_ ? "GPU engine on " + dev_->device_name()
                : "CPU engine, pair pass " + sim::pair_kernel_name(sim_.pair_kernel()))
       << "\n";
  for (const auto& w : warnings_) log_ << "warning: " << w << "\n";
  log_ << "\n" << output::describe_case(cfg_) << "\n";
  log_ << "sampling: every " << sample_every_ << " steps (" << 1.0 / (sample_every_ * cfg_.run.dt_s)
       << " Hz)\n";
  log_.flush();
}

void Runner::report_progress(const std::string& label) {
  const double f = std::min(1.0, static_cast<double>(sim_.step_count()) / static_cast<double>(total_steps_estimate_));
  progress_.update(f, label, sim_.time_s());
}


void Runner::after_step() {
  if (sim_.drum_rotating()) rotation_time_s_ += sim_.dt_s();
  const std::uint64_t n = sim_.step_count();
  if (!defer_outputs_) outputs_due();
  if (checkpoint_every_ && n % checkpoint_every_ == 0) checkpoint();
  if ((n & 63) == 0) report_progress(current_phase_);
  if (abort_at_step() && n == abort_at_step()) std::_Exit(137);
  if (signal_at_step() && n == signal_at_step()) std::raise(SIGTERM);
  if (g_stop_signal && !defer_stop_) stop_on_signal();
}

void Runner::outputs_due() {
  const std::uint64_t n = sim_.step_count();
  if (n % sample_every_ == 0) sample();
  if (snapshot_every_ && n % snapshot_every_ == 0 && last_snapshot_step_ != n) snapshot();
  if (frame_every_ && n % frame_every_ == 0) frame();
  // (image k after step (k + 1) n, as the frames)
  if (speed_image_every_ && n % speed_image_every_ == 0) speed_image(n / speed_image_every_ - 1);
}

// What the run writes in DIR must be files (and its snapshot folders folders): a folder named
// series.csv took the series into series.csv/series.csv, and one named trace.csv stopped the run
// with an "internal error" from the file system.
void Runner::check_output_names() const {
  std::error_code ec;
  for (const char* f : {"series.csv", "trace.csv", "run.log", "responses.csv", "snapshots.pvd", "bodies.pvd"}) {
    const fs::path p = fs::path(opt_.out_dir) / f;
    if (fs::exists(p, ec) && !fs::is_regular_file(p, ec))
      throw OutputError("--out " + opt_.out_dir + ": " + p.string() + " is not a file (a folder?); remove it or choose another --out");
  }
  if (opt_.resume)
    for (const char* d : {"snapshots", "bodies", "frames", "speed_images"}) {
      const fs::path p = fs::path(opt_.out_dir) / d;
      if (fs::exists(p, ec) && !fs::is_directory(p, ec))
        throw OutputError("--out " + opt_.out_dir + ": " + p.string() + " is not a folder; remove it or choose another --out");
    }
}

// A folder of the run's outputs in DIR (made if missing): one line and exit status 4 if it cannot be.
void Runner::make_output_folder(const char* name) const {
  std::error_code ec;
  fs::create_directories(fs::path(opt_.out_dir) / name, ec);
  if (ec) throw OutputError("--out " + opt_.out_dir + ": cannot create the folder " + name + " (" + ec.message() + ")");
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


RunSummary Runner::run() {
  if (opt_.resume) {
    if (!fs::exists(opt_.out_dir + "/checkpoint.bin"))
      throw Error("--resume: " + opt_.out_dir + "/checkpoint.bin does not exist (nothing to resume)");
    lock_ = output::lock_output_dir(opt_.out_dir);
    check_output_names();
  } else {
    output::prepare_output_dir(opt_.out_dir);
    lock_ = output::lock_output_dir(opt_.out_dir);
    check_output_names();
    // A fresh run replaces the outputs of an earlier run in the same folder: an old checkpoint must
    // never be resumed, and stale snapshots, frames or trace would be mistaken for this run's.
    if (std::error_code ec; fs::remove(opt_.out_dir + "/checkpoint.bin", ec), ec)
      throw OutputError("--out " + opt_.out_dir + ": cannot remove the old checkpoint.bin (" + ec.message() + ")");
    for (const char* old : {"trace.csv", "responses.csv", "snapshots", "bodies", "frames", "speed_images",
                            "snapshots.pvd", "bodies.pvd"})  // (until the first snapshot the .pvd named the old files)
      if (std::error_code ec; fs::remove_all(opt_.out_dir + "/" + old, ec), ec)
        throw OutputError("--out " + opt_.out_dir + ": cannot remove the old " + old + " (" + ec.message() + ")");
    remove_analysis_outputs();  // (a resumed run: once its checkpoint is accepted, resume())
  }
  if (opt_.threads > 0) omp_set_num_threads(opt_.threads);
  make_output_folder("snapshots");
  make_output_folder("bodies");
  if (cfg_.output.frame_every_s) make_output_folder("frames");
  // Speed images: by default in drum runs of builds with images (the lean build has none).
#if BIODEM_HAVE_OPENCV
  speed_images_ = built_.drum && cfg_.output.speed_images.value_or(true);
  if (speed_images_) {
    speed_scale_m_s_ = case_file::speed_image_scale_m_s(cfg_);  // (the number run.log states)
    if (cfg_.output.speed_image_every_s)
      speed_image_every_ = std::max<std::uint64_t>(1, steps_for(*cfg_.output.speed_image_every_s, cfg_.run.dt_s));
    make_output_folder("speed_images");
  }
#endif
  {
    std::ifstream in(cfg_.source_path, std::ios::binary);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    case_hash_ = checkpoint::fnv1a(text.data(), text.size());
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
  if (cfg_.drum) {  // [output] surface_bin_m, surface_wall_zone_m: metres to pixels of the raster
    const double px_per_m = analysis::rendered_disc(surface_params_.raster_px, analysis::BacklitStyle{}).radius_px /
                            (0.5 * cfg_.drum->diameter_m);
    if (cfg_.output.surface_bin_m)
      surface_params_.image.bin_px = std::max(1, static_cast<int>(std::lround(*cfg_.output.surface_bin_m * px_per_m)));
    if (cfg_.output.surface_wall_zone_m) surface_params_.image.wall_zone_px = *cfg_.output.surface_wall_zone_m * px_per_m;
  }
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
    log_ << "\nresumed from checkpoint.bin at t = " << sim_.time_s() << " s (step " << sim_.step_count() << ")\nbuild: "
         << output::build_description() << ", threads: " << omp_get_max_threads() << "\n";
    log_ << resume_note_;
    check_log();
    series_ = std::make_unique<output::SeriesWriter>(opt_.out_dir + "/series.csv", true);
    if (cfg_.output.trace) trace_ = std::make_unique<std::ofstream>(opt_.out_dir + "/trace.csv", std::ios::app);
    pvd_ = std::make_unique<output::PvdCollection>(opt_.out_dir + "/snapshots.pvd");
    pvd_bodies_ = std::make_unique<output::PvdCollection>(opt_.out_dir + "/bodies.pvd");
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
    check_log();
    series_ = std::make_unique<output::SeriesWriter>(opt_.out_dir + "/series.csv", false);
    if (cfg_.output.trace) {
      trace_ = std::make_unique<std::ofstream>(opt_.out_dir + "/trace.csv", std::ios::trunc);
      *trace_ << "time_s,body_id,x_m,y_m,z_m,vx_m_s,vy_m_s,vz_m_s,wx_rad_s,wy_rad_s,wz_rad_s\n";
    }
    pvd_ = std::make_unique<output::PvdCollection>(opt_.out_dir + "/snapshots.pvd");
    pvd_bodies_ = std::make_unique<output::PvdCollection>(opt_.out_dir + "/bodies.pvd");
  }
  if (opt_.on_start) opt_.on_start();
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
  // The final state: a later --resume finds nothing left to do. Also without periodic
  // checkpoints when one exists (a signal's, or the one this run resumed from): left behind, a
  // second --resume would go back to it and cut the finished outputs short.
  if (checkpoint_every_ || fs::exists(opt_.out_dir + "/checkpoint.bin")) checkpoint();
  series_->flush();
  if (trace_) {
    trace_->flush();
    check_trace();
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  RunSummary r;
  r.steps = sim_.step_count();
  r.simulated_s = sim_.time_s();
  r.wall_s = wall;
  r.bodies = sim_.bodies().size();
  r.spheres = sim_.spheres().size();
  const double done = static_cast<double>(r.steps - steps_at_start);
  const double rate = wall > 0 ? static_cast<double>(r.spheres) * done / wall : 0.0;
  if (!sim_.sinks().empty()) {
    // (the removed count holds the lost bodies removed as well: named apart, not counted twice)
    const std::uint64_t lost = sim_.lost_bodies(), sunk = sim_.removed_bodies() - std::min(lost, sim_.removed_bodies());
    log_ << "sinks removed " << sunk << " bodies";
    if (lost)
      log_ << "; with the " << lost << " lost bodies removed too, " << sim_.removed_mass_kg() << " kg in all\n";
    else
      log_ << ", " << sim_.removed_mass_kg() << " kg\n";
  }
  if (sim_.lost_bodies())
    log_ << "WARNING: lost bodies removed (left the drum or the [run] bounds box): " << sim_.lost_bodies()
         << (cfg_.bulk_test ? " (the bulk test's responses count them as gone)" : "") << "\n";
  log_ << "finished: " << r.steps << " steps, " << r.simulated_s << " s simulated, wall " << wall << " s, "
       << rate << " sphere-steps/s";
  if (dev_)
    log_ << ", " << (done > 0 ? 1e6 * wall / done : 0.0) << " us/step on " << dev_->device_name()
         << ", device neighbour builds " << dev_->list_builds() << ", row widenings " << dev_->row_widenings()
         << " (row capacity " << dev_->row_capacity() << ")\n";
  else
    log_ << " (" << rate / omp_get_max_threads() << " per thread), neighbour builds " << sim_.neighbor_list().builds()
         << "\n";
  if (dev_ && dev_->removal_tests())
    log_ << "GPU removal tests (sinks, lost bodies; every 10th step): " << dev_->removal_tests() << ", "
         << dev_->removal_uploads() << " of them removed bodies (a download and an upload each)\n";
  if (dev_)
    log_ << "GPU runs of steps: " << dev_->graph_runs() << " launched as CUDA graphs, " << dev_->plain_runs()
         << " kernel by kernel; " << dev_->waitless_list_checks()
         << " list checks read the motion queued before a run's last step; the list guard stopped the device "
         << dev_->guard_stops() << " times (a drift past half the skin: the steps after it taken back, the list "
            "rebuilt there)\n";
  if (dev_) log_ << "GPU contact kernels: " << dev_->contact_kernels() << "\n";
  if (dev_) log_ << "GPU list build: " << dev_->list_build_kernel() << ", " << dev_->grouped_list_builds() << " of "
                 << dev_->list_builds() << " builds grouped\n";
  if (dev_ && !dev_->profile_report().empty()) log_ << dev_->profile_report() << "\n";
  check_log();
  std::ostringstream msg;
  msg << "done: " << r.steps << " steps (" << r.simulated_s << " s simulated) in " << output::format_duration(wall)
      << "; outputs in " << opt_.out_dir << " (series.csv, snapshots.pvd" << (speed_images_ ? ", speed_images/" : "")
      << ", run.log)";
  progress_.finish(msg.str());
  return r;
}


RunSummary run_case(const case_file::LoadedCase& loaded, const RunOptions& options) {
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
