#include "driver/runner.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "case_file/derived_quantities.hpp"
#include "core/error.hpp"
#include "scenario/insertion.hpp"

namespace biodem::driver {

// Insertion in waves (SPEC 5; regions: issue 9): each wave places what fits into the drum or
// the region, then the particles fall for wave_fall_s (default: the free fall over the drum
// diameter, the box diagonal or the cylinder height) before the next wave; mode = "pack" places
// all in one wave. Three waves in a row that place nothing stop the run. Checkpoints may be taken
// during the falls: insertion_ holds what a resumed run needs to go on (issue 10, item 5).
void Runner::insert() {
  if (!cfg_.insertion || built_.populations.empty() ||
      (cfg_.insertion->region == config::Insertion::Region::Drum && !built_.drum)) {
    insertion_ = checkpoint::InsertionProgress{};  // nothing to insert
    return;
  }
  const auto& ins = *cfg_.insertion;
  const bool drum = ins.region == config::Insertion::Region::Drum;
  const std::uint64_t count = case_file::implied_particle_count(cfg_);
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
    insertion_ = checkpoint::InsertionProgress{};
    insertion_.active = true;
    insertion_.rng = rng;
  }
  current_phase_ = "insert";
  bool fell = false;  // a fall came before the next wave: its last step's outputs wait for the wave
  for (;;) {
    if (falling) {
      // A wave always follows a fall, at the time of its last step: that step's outputs are
      // written after the wave (below, or by finish_insertion), so that a time has one sample and
      // one snapshot, of the state with the wave's particles.
      while (insertion_.fall_step < fall_steps) {
        if (dev_) {  // (runs of steps, as the phases: graphs, queued checks, the timed choice)
          const auto a = advance_on_device(fall_steps - insertion_.fall_step, [&](const gpu::DeviceEngine::Advanced&) {
            ++insertion_.fall_step;
            defer_outputs_ = insertion_.fall_step == fall_steps;
          });
          if (a.steps == 0) throw InternalError("internal: the GPU engine made no step of an insertion fall");
          continue;
        }
        advance();
        ++insertion_.fall_step;
        defer_outputs_ = insertion_.fall_step == fall_steps;
        after_step();
      }
      defer_outputs_ = false;
      falling = false;
      fell = true;
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
      if (fell) outputs_due();  // (the last wave's: finish_insertion)
      insertion_.fall_step = 0;
      falling = true;
    }
    last_wave_after_fall_ = fell;
  }
  insertion_ = checkpoint::InsertionProgress{};  // done: later checkpoints carry no insertion state
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
  sample();  // (each once per step: the outputs of the last fall's last step wait for this)
  if (last_snapshot_step_ != sim_.step_count()) snapshot();
  if (last_wave_after_fall_) outputs_due();  // a frame or speed image due at the fall's last step
  last_wave_after_fall_ = false;
  if (checkpoint_every_) checkpoint();  // resumable from the end of insertion on
}

}  // namespace biodem::driver
