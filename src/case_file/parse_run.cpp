// Case file (SPEC 11; docs/case_file.md): [run], [contact], [[phase]] and [output].
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <string>
#include <vector>


#include "case_file/case_parser_detail.hpp"
#include "case_file/derived_quantities.hpp"
#include "config/steps.hpp"

namespace biodem::case_file::detail {

void CaseParser::parse_run() {
  const toml::table* t = single("run");
  if (!t) fail("[run]: required table is missing (it holds dt_s)");
  Reader r(file_, *t, "[run]", false,
           {"dt_s", "seed", "gravity_m_s2", "allow_large_dt", "allow_initial_overlap", "skin_m", "device",
            "lost_particles", "bounds_min_m", "bounds_max_m"});
  auto& run = cfg_.run;
  if (auto dev = r.opt_string("device")) {
    if (*dev == "cpu") run.device = config::Device::Cpu;
    else if (*dev == "gpu") run.device = config::Device::Gpu;
    else if (*dev == "gpu-emulated") run.device = config::Device::GpuEmulated;
    else r.fail("device", "must be \"cpu\", \"gpu\" or \"gpu-emulated\"");
  }
  if (auto lp = r.opt_string("lost_particles")) {
    if (*lp == "remove") run.remove_lost_particles = true;
    else if (*lp != "stop") r.fail("lost_particles", "must be \"stop\" (default) or \"remove\"");
  }
  run.bounds_min_m = r.opt_vec3("bounds_min_m");
  run.bounds_max_m = r.opt_vec3("bounds_max_m");
  if (run.bounds_min_m.has_value() != run.bounds_max_m.has_value())
    r.fail(run.bounds_min_m ? "bounds_min_m" : "bounds_max_m", "bounds_min_m and bounds_max_m go together");
  if (run.bounds_min_m)
    for (int k = 0; k < 3; ++k)
      if (!((*run.bounds_min_m)[k] < (*run.bounds_max_m)[k]))
        r.fail("bounds_max_m", "must exceed bounds_min_m on every axis");
  run.dt_s = r.real("dt_s", kPositive);
  run.seed = r.opt_uint("seed", 0).value_or(1);
  if (auto g = r.opt_vec3("gravity_m_s2")) run.gravity_m_s2 = *g;
  run.allow_large_dt = r.opt_bool("allow_large_dt").value_or(false);
  run.allow_initial_overlap = r.opt_bool("allow_initial_overlap").value_or(false);
  run.skin_m = r.opt_real("skin_m", kPositive);
}

void CaseParser::parse_contact() {
  const toml::table* t = single("contact");
  if (!t) return;
  Reader r(file_, *t, "[contact]", false, {"wall_rolling_reference", "tangential_reduce"});
  cfg_.contact.tangential_reduce = r.opt_bool("tangential_reduce").value_or(false);
  if (auto ref = r.opt_string("wall_rolling_reference")) {
    if (*ref == "wall") cfg_.contact.wall_rolling_reference = config::WallRollingReference::Wall;
    else if (*ref == "lab") cfg_.contact.wall_rolling_reference = config::WallRollingReference::Lab;
    else r.fail("wall_rolling_reference", "must be \"wall\" (relative to the wall) or \"lab\" (LIGGGHTS 3.8.0)");
  }
}

void CaseParser::parse_phases() {
  const auto list = entries("phase");
  if (cfg_.bulk_test) {
    if (!list.empty()) fail(std::string("[[phase]]: the [") + bulk_block() + "] test defines its own phases (fill, lift or gate, rest); remove the [[phase]] entries");
    return;
  }
  if (list.empty()) fail("[[phase]]: at least one phase is required (name and steps, duration_s or revolutions)");
  for (std::size_t i = 0; i < list.size(); ++i) {
    Reader r(file_, *list[i], entry_path("phase", i, name_label(*list[i])), true,
             {"name", "steps", "duration_s", "revolutions", "until_mean_kinetic_energy_j", "max_duration_s",
              "min_duration_s", "settle_hold_s", "settle_energy", "rotate"});
    config::Phase p;
    p.name = r.string("name");
    if (p.name.empty()) r.fail("name", "must not be empty");
    // A length that rounds to no step (round(seconds / dt) = 0) is a phase the run cannot make.
    auto no_step_refused = [&](const char* key, double seconds) {
      if (config::steps_for(seconds, cfg_.run.dt_s) == 0)
        r.fail(key, (std::string(key) == "revolutions" ? num(seconds) + " s, " : std::string()) +
                        "less than half the time step ([run].dt_s = " + num(cfg_.run.dt_s) +
                        " s): the phase would make no step");
    };
    const char* lengths[] = {"steps", "duration_s", "revolutions", "until_mean_kinetic_energy_j"};
    std::vector<std::string_view> given;
    for (auto k : lengths)
      if (r.has(k)) given.push_back(k);
    if (given.empty())
      r.missing("steps", " (a phase needs one of steps, duration_s, revolutions or until_mean_kinetic_energy_j)");
    if (given.size() > 1)
      r.fail(given[1], "a phase takes exactly one of steps, duration_s, revolutions, until_mean_kinetic_energy_j "
                       "(also given: " + std::string(given[0]) + ")");
    const bool settle = given[0] == "until_mean_kinetic_energy_j";
    if (!settle)
      for (auto k : {"max_duration_s", "min_duration_s", "settle_hold_s", "settle_energy"})
        if (r.has(k)) r.fail(k, "only used with until_mean_kinetic_energy_j (a settle criterion)");
    if (r.has("steps")) {
      p.length = config::PhaseLength::Steps;
      p.steps = *r.opt_uint("steps", 1);
    } else if (r.has("duration_s")) {
      p.length = config::PhaseLength::Duration;
      p.duration_s = r.real("duration_s", kPositive);
      no_step_refused("duration_s", p.duration_s);
    } else if (r.has("revolutions")) {
      p.length = config::PhaseLength::Revolutions;
      p.revolutions = r.real("revolutions", kPositive);
      if (!cfg_.drum) r.fail("revolutions", "needs a [drum]");
      if (cfg_.drum->rpm == 0.0) r.fail("revolutions", "needs a turning drum ([drum].rpm = 0)");
      no_step_refused("revolutions", p.revolutions * 60.0 / std::abs(cfg_.drum->rpm));
    } else {
      // Settle criterion: stored as a Duration phase capped at max_duration_s, so that the
      // phase length is always well defined; the criterion may end it earlier.
      p.until_mean_kinetic_energy_j = r.real("until_mean_kinetic_energy_j", kPositive);
      if (!r.has("max_duration_s")) r.missing("max_duration_s", " (the cap of a settle criterion)");
      p.max_duration_s = r.real("max_duration_s", kPositive);
      p.min_duration_s = r.real_or("min_duration_s", 0.0, kNonNegative);
      p.settle_hold_s = r.real_or("settle_hold_s", p.settle_hold_s, kPositive);
      if (p.min_duration_s > *p.max_duration_s) r.fail("min_duration_s", "must not exceed max_duration_s");
      no_step_refused("max_duration_s", *p.max_duration_s);
      // (in steps, as the run counts them: hold max(1, round(hold / dt)) within round(cap / dt))
      if (std::max<std::uint64_t>(1, config::steps_for(p.settle_hold_s, cfg_.run.dt_s)) >
          config::steps_for(*p.max_duration_s, cfg_.run.dt_s)) {
        if (r.has("settle_hold_s"))
          r.fail("settle_hold_s", "exceeds max_duration_s = " + num(*p.max_duration_s) +
                                      " s: the criterion could never be met");
        r.fail("max_duration_s", "is shorter than settle_hold_s = " + num(p.settle_hold_s) +
                                     " s (its default): the criterion could never be met");
      }
      if (auto e = r.opt_string("settle_energy")) {
        if (*e == "translational") p.translational_criterion = true;
        else if (*e != "total") r.fail("settle_energy", "must be \"total\" (default) or \"translational\"");
      }
      p.length = config::PhaseLength::Duration;
      p.duration_s = *p.max_duration_s;
    }
    p.rotate = r.opt_bool("rotate").value_or(p.length == config::PhaseLength::Revolutions);
    if (p.length == config::PhaseLength::Revolutions && !p.rotate)
      r.fail("rotate", "a phase given in revolutions turns the drum");
    if (p.rotate && !cfg_.drum) r.fail("rotate", "there is no [drum] to rotate");
    cfg_.phases.push_back(p);
  }
}

void CaseParser::parse_output() {
  const toml::table* t = single("output");
  if (!t) return;
  Reader r(file_, *t, "[output]", false,
           {"sample_hz", "snapshot_every_s", "checkpoint_every_s", "trace", "frame_every_s", "frame_size_px",
            "surface_bin_m", "surface_wall_zone_m", "speed_images", "speed_image_max_m_s", "speed_image_size_px", "speed_image_every_s"});
  auto& o = cfg_.output;
  o.sample_hz = r.real_or("sample_hz", o.sample_hz, kPositive);
  o.snapshot_every_s = r.opt_real("snapshot_every_s", kPositive);
  o.checkpoint_every_s = r.opt_real("checkpoint_every_s", kPositive);
  o.trace = r.opt_bool("trace").value_or(false);
  o.frame_every_s = r.opt_real("frame_every_s", kPositive);
  o.frame_size_px = static_cast<std::uint32_t>(r.opt_uint("frame_size_px", 64, 16384).value_or(o.frame_size_px));
  o.surface_bin_m = r.opt_real("surface_bin_m", kPositive);
  o.surface_wall_zone_m = r.opt_real("surface_wall_zone_m", kPositive);
  o.speed_images = r.opt_bool("speed_images");
  o.speed_image_max_m_s = r.opt_real("speed_image_max_m_s", kPositive);
  o.speed_image_every_s = r.opt_real("speed_image_every_s", kPositive);
  o.speed_image_size_px =
      static_cast<std::uint32_t>(r.opt_uint("speed_image_size_px", 256, 4096).value_or(o.speed_image_size_px));
}

}  // namespace biodem::case_file::detail
