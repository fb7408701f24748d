// The run of one case (`biodem run`, SPEC 5 and 11), internal to src/driver: a Runner holds the
// simulation, its engine (CPU, or the GPU engine with the host copy synchronised on demand), the
// output writers and where the run is (for checkpoints). Its jobs live in one file each:
//   run_driver.cpp     the run from start to end, engine access, signals, run.log header
//   phases.cpp         the phase plan from the case, one phase (criteria, wall motion, timings)
//   insertion.cpp      insertion in waves, also resumed from a checkpoint
//   run_outputs.cpp    samples (series.csv, trace.csv), snapshots (VTK), back-lit frames
//   bulk_responses.cpp responses.csv of a bulk test
//   run_checkpoint.cpp checkpoint.bin: writing, resuming, truncating the appended outputs
#pragma once
#include <cstdint>
#include <fstream>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#if BIODEM_HAVE_OPENCV
#include "analysis/free_surface.hpp"
#endif
#include "case_file/case_parser.hpp"
#include "checkpoint/checkpoint.hpp"
#include "config/steps.hpp"
#include "core/vec3.hpp"
#include "driver/build_simulation.hpp"
#include "driver/run_driver.hpp"
#include "gpu/device_engine.hpp"
#include "output/output_dir.hpp"
#include "output/progress.hpp"
#include "output/series_csv.hpp"
#include "output/vtk_writer.hpp"

namespace biodem::driver {

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
double process_cpu_s();
using config::steps_for;  // round(seconds / dt), config/steps.hpp
/// The phases of a case in steps (a settle criterion, a wall motion ...).
std::vector<PhasePlan> plan_phases(const config::CaseConfig& c);

class Runner {
 public:
  Runner(const case_file::LoadedCase& loaded, const RunOptions& opt);

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
  /// speed_images/speed_NNNNNN.png of the current state, NNNNNN = index.
  void speed_image(std::size_t index);
  void checkpoint();
  void resume();
  void after_step();
  void outputs_due();                // the sample, snapshot, frame and speed image due at this step
  void check_output_names() const;  // the files the run writes in DIR are not folders
  void make_output_folder(const char* name) const;
  void sample();
  void snapshot();
  double revolution() const;
  void report_progress(const std::string& label);
  [[noreturn]] void stop_on_signal();
  /// One time step on the CPU engine (the GPU engine: advance_on_device).
  void advance(bool next_follows = false);  // next_follows: see sim::Simulation::step
  /// GPU engine: the number of steps, at most `limit`, that the device may make in one
  /// DeviceEngine::advance call: it ends at the first step whose after_step uses the state
  /// (sample, snapshot, frame, checkpoint, the test hooks), after at most kDeviceRun steps.
  std::uint64_t device_run_length(std::uint64_t limit) const;
  /// GPU engine: one DeviceEngine::advance of device_run_length(limit) steps, then, for each step
  /// made, `each` (given the advance's result) and after_step, with the host clock at that step.
  gpu::DeviceEngine::Advanced advance_on_device(std::uint64_t limit,
                                                const std::function<void(const gpu::DeviceEngine::Advanced&)>& each);
  /// Whether after_step at step n uses the state (the host must be current then).
  bool host_needs_state_at(std::uint64_t n) const;
  /// One phase's steps on the GPU engine: runs of steps on the device, then after_step for each
  /// step made, with the host clock at that step (phases.cpp).
  void run_phase_on_device(const PhasePlan& p, std::uint64_t max_steps, std::uint64_t& k, std::uint64_t& below,
                           bool& settled);
  /// GPU engine: brings the host Simulation up to date (with the contact history when `history`).
  void sync(bool history);
  double kinetic_energy_j();
  double translational_kinetic_energy_j();
  /// Neighbour-list builds so far: the device list's on the GPU engine, else the CPU list's.
  std::uint64_t list_builds() const;

  /// Throws if trace.csv's stream failed (a full disk, a file size limit): outputs are not
  /// given up silently.
  void check_trace() const;
  void check_log();  // flushes run.log and stops the run if it could not be written
  /// Removes the tables and plots of an earlier `biodem analyze` of the output folder.
  void remove_analysis_outputs();

  output::DirLock lock_;  // the output folder, held for the run (output::lock_output_dir)
  const config::CaseConfig& cfg_;
  std::vector<std::string> warnings_;
  RunOptions opt_;
  BuiltCase built_;
  sim::Simulation& sim_;
  output::Progress progress_;
  std::unique_ptr<output::SeriesWriter> series_;
  std::unique_ptr<std::ofstream> trace_;
  std::unique_ptr<output::PvdCollection> pvd_, pvd_bodies_;
  std::ofstream log_;
  std::uint64_t sample_every_ = 1, snapshot_every_ = 0, frame_every_ = 0, checkpoint_every_ = 0;
  bool speed_images_ = false;   // speed images ([output] speed_images): at each snapshot, or
  std::uint64_t speed_image_every_ = 0;  // every this many steps ([output] speed_image_every_s)
  double speed_scale_m_s_ = 0;  // the top of their colour scale
  std::uint64_t last_sample_step_ = ~std::uint64_t{0}, last_snapshot_step_ = ~std::uint64_t{0};
#if BIODEM_HAVE_OPENCV
  analysis::SurfaceParams surface_params_{};
#endif
  std::uint64_t case_hash_ = 0;
  // Where the run is, for checkpoints.
  std::size_t phase_index_ = 0;
  std::uint64_t phase_step_ = 0, settle_counter_ = 0;
  checkpoint::RunProgress resumed_;
  bool resumed_run_ = false;
  std::string resume_note_;  // for run.log: the engine or GPU sum family a resumed run goes on with, when it matters
  std::string engine_name() const;  // "cpu", "gpu", "gpu-emulated" (as [run] device and checkpoints name it)
  void adopt_checkpoint_engine(const std::string& path);  // resume(): the checkpoint's GPU contact sums, the notes
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
  // The last step of an insertion fall: its outputs wait for the wave made at the same time, so
  // that one sample and one snapshot show that time's state (with the wave's particles).
  bool defer_outputs_ = false;
  bool last_wave_after_fall_ = false;  // the last wave followed a fall: finish_insertion writes its outputs
  bool defer_stop_ = false;  // after_step of a step the device has already gone past: a signal waits for the run's last step
  checkpoint::InsertionProgress insertion_;  // while inserting: what a checkpoint must carry
};

}  // namespace biodem::driver
