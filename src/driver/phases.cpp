// The phases of a run (SPEC 5): the plan from the case, and one phase: steps until its length
// or its rest criterion, the wall it moves (bulk tests), and its timings in run.log.
#include "driver/runner.hpp"

#include <omp.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "core/parallel.hpp"
#include "core/spin_team.hpp"

namespace biodem::driver {

/// CPU time of the whole process (all threads), user + system, in seconds.
double process_cpu_s() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
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

void Runner::run_phase_on_device(const PhasePlan& p, std::uint64_t max_steps, std::uint64_t& k, std::uint64_t& below,
                                 bool& settled) {
  // The device evaluates the settle criterion itself after every step (the same rule and
  // arithmetic as the loop of run_phase on the kinetic energy it sums) and makes no further
  // moves once it is met, so the host waits for it only at list checks and at the end of each run
  // of steps, and the phase ends at the step it would end at one step at a time.
  if (p.criterion && !settled)
    dev_->begin_settle({p.ke_threshold_j, p.translational, p.min_steps, p.hold_steps}, k, below);
  while (!settled && k < max_steps) {
    const gpu::DeviceEngine::Advanced a = advance_on_device(max_steps - k, [&](const gpu::DeviceEngine::Advanced& r) {
      if (p.criterion) below = r.below;
      ++k;
      phase_step_ = k;
      settle_counter_ = below;  // the counter after the run's last step: checkpoints are written only there
    });
    if (p.criterion) {
      below = a.below;
      settled = a.settled;
    }
    if (a.steps == 0) break;  // (not expected: the criterion was not met before the run)
  }
  if (p.criterion) dev_->end_settle();
}

void Runner::run_phase(const PhasePlan& p, std::size_t index, std::uint64_t start_step, std::uint64_t below) {
  current_phase_ = p.name;
  phase_index_ = index;
  sim_.set_drum_rotation(p.rotate);
  if (dev_) {
    dev_->sync_walls();
    dev_->retime_kernels();  // (the bed of a new phase: the contact kernels are timed again)
  }
  log_ << "phase " << index + 1 << " '" << p.name << "' " << (start_step ? "resumes" : "starts") << " at t = "
       << sim_.time_s() << " s (step " << sim_.step_count() << "), rotation " << (p.rotate ? "on" : "off") << "\n";
  std::uint64_t k = start_step;
  std::uint64_t max_steps = p.max_steps;
  if (p.move_wall && start_step == 0) {
    if (p.move_by_fill_height) {
      // [heap]: lift by the settled fill's height plus the margin (SPEC 7), not the whole tube.
      sync(false);  // (GPU engine: the settled fill's positions)
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
    if (dev_) dev_->sync_walls();  // (the device's copy of the wall and its schedule)
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
  const std::uint64_t team_sleeps0 = team().sleeps();
  const std::uint64_t builds0 = list_builds();
  const auto t0 = std::chrono::steady_clock::now();
  bool settled = p.criterion && k >= p.min_steps && below >= p.hold_steps;
  if (dev_) run_phase_on_device(p, max_steps, k, below, settled);
  while (!dev_ && !settled && k < max_steps) {
    // The CPU step may end with the next step's drift done (Simulation::step) when nothing
    // reads the state in between: no criterion to evaluate, no output, not the phase's end.
    advance(!p.criterion && k + 1 < max_steps && !host_needs_state_at(sim_.step_count() + 1));
    ++k;
    if (p.criterion) {
      const double ke = p.translational ? translational_kinetic_energy_j() : kinetic_energy_j();
      const double mean_ke = sim_.bodies().size() ? ke / sim_.bodies().size() : 0.0;
      below = mean_ke < p.ke_threshold_j ? below + 1 : 0;
      settled = k >= p.min_steps && below >= p.hold_steps;
    }
    phase_step_ = k;
    settle_counter_ = below;
    defer_stop_ = sim_.steps_ahead();  // a signal stops the run after the next step, not half a step ahead
    after_step();
    defer_stop_ = false;
  }
  k -= start_step;
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double rate = wall > 0.0 ? static_cast<double>(sim_.spheres().size()) * static_cast<double>(k) / wall : 0.0;
  log_ << "phase '" << p.name << "' ends at t = " << sim_.time_s() << " s after " << k << " steps";
  log_ << "; wall " << wall << " s, " << (k ? 1e6 * wall / static_cast<double>(k) : 0.0) << " us/step, " << rate
       << " sphere-steps/s";
  // Neighbour-list builds in the phase (the device list's on the GPU engine): what the skin
  // costs in this phase, for the benchmarks and the skin choice (docs/gpu.md section 4).
  const std::uint64_t builds = list_builds() - builds0;
  if (!dev_) log_ << ", " << rate / omp_get_max_threads() << " sphere-steps/s/thread";
  {
    char buf[96];
    std::snprintf(buf, sizeof buf, "; %llu list builds", static_cast<unsigned long long>(builds));
    log_ << buf;
    if (builds) {
      std::snprintf(buf, sizeof buf, " (one per %.1f steps)", static_cast<double>(k) / static_cast<double>(builds));
      log_ << buf;
    }
  }
  if (!dev_) {
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
    char buf[768];
    std::snprintf(buf, sizeof buf,
                  "\nprofile '%s' (us/step over %llu steps, %llu list builds): step %.1f = drift %.1f + list %.1f + "
                  "pairs %.1f (threads busy %.0f %%) + gather/walls/kick %.1f (with the next step's drift where it "
                  "follows); outside step() %.1f; %llu waits of the thread team slept (after a %lld us spin)",
                  p.name.c_str(), static_cast<unsigned long long>(q.steps), static_cast<unsigned long long>(q.builds),
                  q.step_s * per, q.drift_s * per, q.list_s * per, q.pairs_s * per,
                  q.pairs_s > 0.0 ? 100.0 * q.pairs_busy_s / q.pairs_s : 0.0, q.gather_s * per,
                  (wall - q.step_s) * per, static_cast<unsigned long long>(team().sleeps() - team_sleeps0),
                  static_cast<long long>(team().spin_us()));
    log_ << buf;
  }
  if (opt_.profile && dev_)
    log_ << "\nprofile '" << p.name << "': --profile times the CPU engine's step; on the GPU engine set "
         << "BIODEM_GPU_PROFILE=1 (docs/gpu.md)";
  if (p.criterion) last_settled_ = below >= p.hold_steps;
  if (p.criterion)
    log_ << (below >= p.hold_steps ? " (settled: mean kinetic energy below threshold)"
                                   : " (max_duration_s reached before the bed was at rest)");
  log_ << "\n";
  // (a line of its own: a calibration campaign's log repeats the WARNING lines of its runs; a
  // bulk test's responses.csv says at_rest of its last phase only)
  if (p.criterion && below < p.hold_steps)
    log_ << "WARNING: phase '" << p.name
         << "' reached its time cap before the bed was at rest: what follows starts from a moving bed\n";
  log_.flush();
}

}  // namespace biodem::driver
