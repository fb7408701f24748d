// checkpoint.bin during a run (docs/architecture.md section 5): what the run adds to the
// simulation state (where it is, the sizes of the appended outputs), and --resume.
#include "driver/runner.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "core/error.hpp"

namespace biodem::driver {
namespace {

namespace fs = std::filesystem;

/// Durably on disk (fsync): the appended outputs before a checkpoint records their sizes, and the
/// folder after the checkpoint's rename (a crash must not leave a checkpoint that counts rows the
/// disk never received, or lose the renamed checkpoint).
void fsync_path(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

/// An appended output the checkpoint counted `bytes` of: it must exist and hold at least that
/// (a shorter file lost rows the checkpoint relies on; extending it would pad with NUL bytes).
void check_for_checkpoint(const std::string& path, std::uint64_t bytes) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec))
    throw Error("--resume: " + path + " is missing (the checkpoint counts " + std::to_string(bytes) +
                " bytes of it); start the run again");
  const auto size = fs::file_size(path);
  if (size < bytes)
    throw Error("--resume: " + path + " has " + std::to_string(size) + " bytes, fewer than the " + std::to_string(bytes) +
                " the checkpoint recorded (rows were lost); start the run again");
}

/// Cuts the output back to what the checkpoint counted; true if that shortened it.
bool truncate_to_checkpoint(const std::string& path, std::uint64_t bytes) {
  if (fs::file_size(path) == bytes) return false;
  fs::resize_file(path, bytes);
  return true;
}

}  // namespace

void Runner::checkpoint() {
  sync(true);
  series_->flush();
  if (trace_) {
    trace_->flush();
    check_trace();
  }
  fsync_path(opt_.out_dir + "/series.csv");
  if (trace_) fsync_path(opt_.out_dir + "/trace.csv");
  checkpoint::RunProgress rp;
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
  rp.engine = engine_name();
  rp.contact_sums = dev_ ? (dev_->fixed_sums() ? "fixed" : "ordered") : "";
  // frame index is implied by the step count
  checkpoint::save_checkpoint(opt_.out_dir + "/checkpoint.bin", sim_, rp);
  fsync_path(opt_.out_dir);
  check_log();  // after the checkpoint: a run stopped here resumes from it
}

std::string Runner::engine_name() const {
  return device_ == config::Device::Gpu ? "gpu" : device_ == config::Device::GpuEmulated ? "gpu-emulated" : "cpu";
}

void Runner::resume() {
  const std::string path = opt_.out_dir + "/checkpoint.bin";
  if (checkpoint::checkpoint_case_hash(path) != case_hash_)
    throw Error("--resume: " + path + " was written for a different case file than " + cfg_.source_path);
  resumed_ = checkpoint::load_checkpoint(path, sim_);
  adopt_checkpoint_engine(path);
  if (dev_) {
    dev_->upload();  // the checkpoint's forces and contact history: the run continues as it was
    device_current_ = true;
    synced_step_ = sim_.step_count();
    synced_history_ = true;
  }
  rotation_time_s_ = resumed_.rotation_time_s;
  snapshot_index_ = resumed_.snapshot_index;
  // Both appended outputs checked before either is cut: a refused resume changes nothing.
  const std::string series = opt_.out_dir + "/series.csv", trace = opt_.out_dir + "/trace.csv";
  check_for_checkpoint(series, resumed_.series_bytes);
  if (cfg_.output.trace) check_for_checkpoint(trace, resumed_.trace_bytes);
  bool cut = truncate_to_checkpoint(series, resumed_.series_bytes);
  if (cfg_.output.trace) cut = truncate_to_checkpoint(trace, resumed_.trace_bytes) || cut;
  // An earlier analysis describes a series that was cut here, or that the run will extend; the
  // resume of a finished run (its final checkpoint: nothing cut, no phase left) keeps it.
  if (cut || resumed_.phase_index < cfg_.phases.size()) remove_analysis_outputs();
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

/// The GPU engine goes on with the family of contact sums the checkpoint was written with, unless
/// BIODEM_GPU_SUMS asks for one: a run killed and resumed without the variable it was started
/// with continues bit for bit. run.log says when the run goes on with another engine or family
/// than the checkpoint's (its outputs from there on are then those of neither run).
void Runner::adopt_checkpoint_engine(const std::string& path) {
  const std::string& was = resumed_.engine;
  if (was.empty()) return;  // a version-5 file: not recorded
  const std::string now = engine_name();
  if (was != now)
    resume_note_ += "note: " + path + " was written by the " + was + " engine; this run goes on with the " + now +
                    " engine from its state (the outputs from here on are not those of an uninterrupted " + was +
                    " run)\n";
  if (!dev_ || resumed_.contact_sums.empty()) return;
  const std::string& fam = resumed_.contact_sums;  // "ordered" or "fixed" (checked by the loader)
  const char* env = std::getenv("BIODEM_GPU_SUMS");
  const std::string current = dev_->fixed_sums() ? "fixed" : "ordered";
  if (env && *env) {
    if (fam != current)
      resume_note_ += "note: " + path + " was written with the GPU engine's " + fam +
                      " contact sums; this run goes on with the " + current +
                      " ones (BIODEM_GPU_SUMS): the outputs from here on are those of neither family's uninterrupted run\n";
    return;
  }
  if (fam == current) return;
  if (fam == "fixed")
    for (const char* other : {"BIODEM_GPU_SUM_LANES", "BIODEM_GPU_WALK_KICK"})
      if (const char* o = std::getenv(other); o && std::string(o) == "1")
        throw Error("--resume: " + path + " was written with the GPU engine's fixed contact sums (BIODEM_GPU_SUMS=fixed), which have no kernel set for " +
                    std::string(other) + " = '1'; unset it, or set BIODEM_GPU_SUMS=ordered to go on with the ordered sums");
  dev_->set_fixed_sums(fam == "fixed");
  resume_note_ += "GPU contact sums: " + fam + ", as " + path + " was written (BIODEM_GPU_SUMS unset)\n";
}

}  // namespace biodem::driver
