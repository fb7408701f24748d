// The GPU engine's kernels executed on CPU threads (Thrust's OpenMP system): the same functors
// that run on a GPU, tested on every commit without one. Each test sets up the same scene twice,
// steps one copy with the CPU engine (the reference) and one with the GPU engine, and compares;
// where a closed form exists, the GPU result is also checked against it.
//
// Tolerances. The two engines evaluate the same force laws with the same arithmetic per contact,
// but sum a sphere's contacts in a different order (CPU: storage order of a half list; GPU:
// stable ids of a full list), so states agree to round-off (1e-16 relative) that collisions
// amplify. One- and two-body scenes must agree to 1e-12 relative; the dense packings to 1e-9 m
// over 300 steps (a sign or factor error in any law moves them by O(1e-6 m) or more).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <string>
#include <map>
#include <memory>
#include <numeric>
#include <random>
#include <vector>

#include "core/error.hpp"
#include "core/parallel.hpp"
#include "gpu/device_engine.hpp"
#include "physics/physics_support.hpp"

using namespace biodem;
using namespace biodem::phys;

namespace {

/// The backend under test: CPU threads by default (CI); BIODEM_TEST_GPU=1 runs the same tests
/// on the CUDA device of a GPU machine.
gpu::Backend backend_under_test() {
  const char* v = std::getenv("BIODEM_TEST_GPU");
  return v && std::string(v) == "1" ? gpu::Backend::Cuda : gpu::Backend::HostThreads;
}
std::unique_ptr<gpu::DeviceEngine> gpu_engine(sim::Simulation& s) { return gpu::make_device_engine(backend_under_test(), s); }
/// The engine with its list checks queued ("1") or waiting for their reduction ("0",
/// BIODEM_GPU_QUEUED_CHECK, read when the engine is made).
std::unique_ptr<gpu::DeviceEngine> gpu_engine_checks(sim::Simulation& s, const char* queued) {
  ::setenv("BIODEM_GPU_QUEUED_CHECK", queued, 1);
  auto e = gpu_engine(s);
  ::unsetenv("BIODEM_GPU_QUEUED_CHECK");
  return e;
}

double uniform(std::mt19937_64& g) { return static_cast<double>(g() >> 11) * 0x1.0p-53; }

/// Steps both copies `steps` times (the GPU copy through the engine) and downloads the GPU state.
void run_pair(sim::Simulation& cpu, gpu::DeviceEngine& eng, std::uint64_t steps) {
  for (std::uint64_t k = 0; k < steps; ++k) {
    cpu.step();
    eng.step();
  }
  eng.download(true);
}

/// Largest distance between the bodies of the two simulations, matched by stable id.
double worst_position_gap(const sim::Simulation& a, const sim::Simulation& b) {
  const auto& ba = a.bodies();
  const auto& bb = b.bodies();
  std::map<std::uint32_t, std::size_t> where;  // (ids have gaps once bodies were removed)
  for (std::size_t q = 0; q < bb.size(); ++q) where[bb.id[q]] = q;
  double worst = 0.0;
  for (std::size_t q = 0; q < ba.size(); ++q) {
    const auto it = where.find(ba.id[q]);
    if (it == where.end()) return HUGE_VAL;  // (a body of one engine missing from the other)
    worst = std::max(worst, norm(ba.position_m[q] - bb.position_m[it->second]));
  }
  return worst;
}

SimSetup bead_setup(double restitution, double friction, double rolling = 0.0, double ced = 0.0) {
  SimSetup su;
  su.particle = {5e6, 0.3, 2500.0};
  su.wall = {5e6, 0.3, 0.0};
  su.particle_particle = {restitution, friction, rolling, ced};
  su.particle_wall = {restitution, friction, rolling, ced};
  su.templates = {sphere_template(1e-3)};
  su.dt_s = 2e-7;
  return su;
}

}  // namespace

TEST(GpuEngine, ReportsHowItRuns) {
  SimSetup su = bead_setup(0.5, 0.0);
  sim::Simulation s = make_simulation(su);
  auto e = gpu_engine(s);
  std::printf("[measured] engine under test: %s\n", e->device_name().c_str());
  if (backend_under_test() == gpu::Backend::HostThreads) {
    EXPECT_NE(e->device_name().find("CPU threads"), std::string::npos);
  }
  if (!gpu::cuda_built()) {
    try {
      gpu::make_device_engine(gpu::Backend::Cuda, s);
      FAIL() << "a build without CUDA must refuse the GPU backend";
    } catch (const Error& err) {
      EXPECT_NE(std::string(err.what()).find("without the CUDA engine"), std::string::npos) << err.what();
    }
  }
}

// Head-on sphere-sphere impact: restitution e = 0.5 out of the GPU engine (1 %, as the CPU test),
// and the same rebound speed as the CPU engine to 1e-12.
TEST(GpuEngine, NormalImpactRestitutionMatchesInputAndCpu) {
  for (double e_in : {0.1, 0.5, 0.87}) {
    SimSetup su = bead_setup(e_in, 0.3);
    sim::Simulation cpu = make_simulation(su), gs = make_simulation(su);
    const double v0 = 0.5;
    for (auto* s : {&cpu, &gs}) {
      add_particle(*s, 0, {-1.05e-3, 0, 0}, {v0, 0, 0});
      add_particle(*s, 0, {1.05e-3, 0, 0}, {-v0, 0, 0});
    }
    auto eng = gpu_engine(gs);
    eng->upload();
    run_pair(cpu, *eng, 6000);
    const double v_cpu = cpu.bodies().velocity_m_s[1].x - cpu.bodies().velocity_m_s[0].x;
    const double v_gpu = gs.bodies().velocity_m_s[1].x - gs.bodies().velocity_m_s[0].x;
    const double e_out = v_gpu / (2.0 * v0);
    report("gpu engine restitution", e_out, e_in);
    EXPECT_NEAR(e_out, e_in, 0.01 * e_in);
    EXPECT_NEAR(v_gpu, v_cpu, 1e-12 * std::abs(v_cpu));
    // Momentum: the two forces of a pair are exact opposites.
    EXPECT_NEAR(gs.linear_momentum().x, 0.0, 1e-18);
  }
}

// Oblique frictional impact on a plane with rolling friction and cohesion: every slot of the
// contact model (Hertz, damping, SJKR, Mindlin with Coulomb limit, EPSD2) at a wall; the GPU and
// CPU trajectories (position, velocity, spin) agree to 1e-12 relative.
TEST(GpuEngine, ObliqueWallImpactWithAllModelsMatchesCpu) {
  for (double angle_deg : {20.0, 60.0}) {
    SimSetup su = bead_setup(0.6, 0.4, 0.3, 2e4);
    sim::Simulation cpu = make_simulation(su), gs = make_simulation(su);
    const double a = angle_deg * std::numbers::pi / 180.0;
    for (auto* s : {&cpu, &gs}) {
      s->add_wall(plane_wall({0, 0, 0}, {0, 1, 0}));
      add_particle(*s, 0, {0, 1.02e-3, 0}, {0.4 * std::sin(a), -0.4 * std::cos(a), 0}, {0, 0, 50});
    }
    auto eng = gpu_engine(gs);
    eng->upload();
    run_pair(cpu, *eng, 3000);
    const Vec3 vc = cpu.bodies().velocity_m_s[0], vg = gs.bodies().velocity_m_s[0];
    const Vec3 wc = cpu.bodies().angular_velocity_rad_s[0], wg = gs.bodies().angular_velocity_rad_s[0];
    std::printf("[measured] oblique %.0f deg: v_cpu (%.9g, %.9g) v_gpu (%.9g, %.9g), w_z cpu %.9g gpu %.9g\n", angle_deg,
                vc.x, vc.y, vg.x, vg.y, wc.z, wg.z);
    EXPECT_GT(vc.y, 0.0) << "the sphere must have bounced";
    EXPECT_LT(norm(vg - vc), 1e-12 * norm(vc));
    EXPECT_LT(norm(wg - wc), 1e-12 * norm(wc));
    EXPECT_LT(worst_position_gap(cpu, gs), 1e-15);
  }
}

// A sphere resting on a plane under gravity: the static Hertz overlap F = (4/3) Y* sqrt(R) d^1.5.
// A bead crossing more than half the skin in one step (2 m/s x 0.2 us = 0.4 um against a half
// skin of 0.25 um): the list is rebuilt at every step's check, before the forces, as the CPU
// engine does, so the GPU engine runs it (it used to stop at the first check, asking for a
// larger skin) and follows the CPU engine through a bead-bead and a bead-wall impact.
TEST(GpuEngine, BeadFasterThanHalfTheSkinPerStepMatchesCpu) {
  for (const char* queued : {"1", "0"}) {
  SCOPED_TRACE(std::string("BIODEM_GPU_QUEUED_CHECK=") + queued);
  SimSetup su = bead_setup(0.5, 0.3);
  sim::Simulation cpu = make_simulation(su), gs = make_simulation(su);
  for (auto* s : {&cpu, &gs}) {
    s->add_wall(plane_wall({1.5e-3, 0, 0}, {-1, 0, 0}));
    add_particle(*s, 0, {-2.5e-3, 0, 0}, {2.0, 0, 0});
    add_particle(*s, 0, {0, 0, 0});
    // A third bead inside a sink from the start: the GPU engine removes it at step 10, the last
    // step of the first run below (the upload it makes there must not count as forces at the new
    // list's positions: the next check, of a sphere 0.4 um from them, rebuilds).
    sim::SinkSpec k;
    k.point_m = {0.0, -5e-3, 0.0};
    s->add_sink(k);
    add_particle(*s, 0, {0, -10e-3, 0});
    s->set_skin(5e-7);
  }
  ASSERT_GT(2.0 * su.dt_s, 0.5 * gs.skin_m());
  auto eng = gpu_engine_checks(gs, queued);
  eng->upload();
  const std::uint64_t steps = 7000, run = 37;
  for (std::uint64_t k = 0; k < steps;) {
    const std::uint64_t n = k == 0 ? 10 : std::min(run, steps - k);
    for (std::uint64_t q = 0; q < n; ++q) cpu.step();
    ASSERT_EQ(eng->advance(n).steps, n);
    k += n;
  }
  eng->download(true);
  ASSERT_EQ(gs.bodies().size(), 2u);
  ASSERT_EQ(cpu.bodies().size(), 2u);
  const Vec3 va_c = cpu.bodies().velocity_m_s[0], vb_c = cpu.bodies().velocity_m_s[1];
  const Vec3 va_g = gs.bodies().velocity_m_s[0], vb_g = gs.bodies().velocity_m_s[1];
  std::printf("[measured] fast beads: v_x cpu %.9g %.9g, gpu %.9g %.9g (m/s)\n", va_c.x, vb_c.x, va_g.x, vb_g.x);
  // The striker (2 m/s) kept (1 - e)/2 of its speed, 0.5 m/s, and was sent back by the struck
  // bead returning from the wall at about e x 1.5 m/s: it only moves towards -x if all three
  // contacts were found. Both impacts dissipate: the kinetic energy ends below the initial 2 m/s's.
  EXPECT_LT(va_c.x, -0.3);
  EXPECT_LT(cpu.bodies().position_m[1].x, 0.5e-3);
  EXPECT_LT(va_c.x * va_c.x + vb_c.x * vb_c.x, 0.5 * 2.0 * 2.0);
  EXPECT_LT(norm(va_g - va_c), 1e-12 * norm(va_c));
  EXPECT_LT(norm(vb_g - vb_c), 1e-12 * norm(vb_c));
  EXPECT_LT(worst_position_gap(cpu, gs), 1e-15);
  }
}

// A sphere outrunning the list check's prediction: two beads overlapping by 0.3 mm at rest push
// apart at 29,000 m/s^2. The first check (after one step) sees 5.7 mm/s and, allowing for twice
// that speed, sets the next check 10 steps later; each bead passes half the 0.1 um skin (50 nm)
// before it. A third bead waits 0.12 um from the right one, beyond the skin: outside the list
// built at the start, reached within 16 steps. The list guard stops the device after the drift
// that takes a bead past half the skin (before any forces there), the host takes back the steps
// launched after it and builds the list at that drift's positions (now with the third bead), as
// the CPU engine does at such a step: the GPU engine follows the CPU engine (before 2026-11-28
// the run stopped, asking for a larger skin; without the guard's flag, the third bead's contact
// is missed for steps and the trajectories part: mutant 50). In every kernel
// family (the fused kick-drift, the separate kernels of a criterion phase, the row walk, the
// entry kernels, the row walk with the body update and its two motion buffers, the order-free
// sums), with queued and waiting checks, for beads and for two-sphere clumps, and with several
// check intervals and first runs of steps, so that the guard stops the device at an even and an
// odd step of a run, at its last step and at the end of an advance.
TEST(GpuEngine, SphereOutrunningTheListCheckIsCaughtByTheGuardAndFollowsCpu) {
  struct Family {
    const char* name;
    void (*set)(gpu::DeviceEngine&);
  };
  const Family families[] = {
      {"default", [](gpu::DeviceEngine&) {}},
      {"criterion phase (separate kernels, settle sums)", [](gpu::DeviceEngine&) {}},
      {"row walk", [](gpu::DeviceEngine& e) { e.set_entry_forces(false); }},
      {"entry kernels", [](gpu::DeviceEngine& e) { e.set_entry_forces(true); }},
      {"row walk with the body update (two buffers)",
       [](gpu::DeviceEngine& e) {
         e.set_entry_forces(false);
         e.set_walk_kick(true);
       }},
      {"order-free sums",
       [](gpu::DeviceEngine& e) {
         e.set_entry_forces(true);
         e.set_fixed_sums(true);
       }},
  };
  std::uint64_t stops = 0, scenes = 0;
  for (const Family& fam : families)
    for (const char* queued : {"1", "0"})
      for (bool clumps : {false, true})
        for (std::uint32_t check_every : {10u, 3u, 16u})
          for (std::uint64_t first : {1u, 4u, 9u}) {
      SCOPED_TRACE(std::string(fam.name) + ", BIODEM_GPU_QUEUED_CHECK=" + queued + (clumps ? ", clumps" : ", beads") +
                   ", check every " + std::to_string(check_every) + ", first run " + std::to_string(first));
      SimSetup su = bead_setup(0.5, 0.3);
      // (two 1 mm spheres 1.2 mm apart, overlapping by 0.8 mm: their clumps overlap by 0.3 mm)
      if (clumps) su.templates = {clump_template({{0, -0.6e-3, 0}, {0, 0.6e-3, 0}}, {1e-3, 1e-3})};
      sim::Simulation cpu = make_simulation(su), gs = make_simulation(su);
      for (auto* s : {&cpu, &gs}) {
        add_particle(*s, 0, {-0.85e-3, 0, 0});
        add_particle(*s, 0, {0.85e-3, 0, 0});
        add_particle(*s, 0, {2.85e-3 + 1.2e-7, 0, 0});
        s->set_skin(1e-7);
      }
      auto eng = gpu_engine_checks(gs, queued);
      fam.set(*eng);
      eng->set_check_every(check_every);
      eng->upload();
      const std::uint64_t runs[] = {first, 7, 10, 37, 3, 64, 2, 200};
      if (std::string(fam.name).starts_with("criterion")) {
        gpu::DeviceEngine::SettleCriterion never;
        never.threshold_j = 0.0;
        never.min_steps = 1000000;
        eng->begin_settle(never, 0, 0);
      }
      std::uint64_t steps = 0;
      for (std::uint64_t n : runs) {
        for (std::uint64_t q = 0; q < n; ++q) cpu.step();
        ASSERT_EQ(eng->advance(n).steps, n);
        steps += n;
      }
      eng->download(true);
      ASSERT_EQ(gs.step_count(), steps);
      const Vec3 va_c = cpu.bodies().velocity_m_s[0], va_g = gs.bodies().velocity_m_s[0];
      stops += eng->guard_stops();
      ++scenes;
      // The bodies separated (1.6 m/s each after the push, beads and clumps) and the third was
      // struck: a sign or a missed contact shows.
      EXPECT_LT(va_c.x, -0.5);
      EXPECT_GT(cpu.bodies().velocity_m_s[2].x, 0.05);
      // (every 3 steps, the checks' rule keeps up with the push: no stop is needed)
      if (check_every >= 10) {
        EXPECT_GT(eng->guard_stops(), 0u) << "the guard must have stopped the device";
      }
      const bool fixed = std::string(fam.name) == "order-free sums";
      // (the order-free sums round each force to a fixed-point grid: 1e-9 there)
      const double tol = fixed ? 1e-9 : 1e-12;
      EXPECT_LT(norm(va_g - va_c), tol * norm(va_c));
      EXPECT_LT(norm(gs.bodies().velocity_m_s[1] - cpu.bodies().velocity_m_s[1]), tol * norm(va_c));
      EXPECT_LT(norm(gs.bodies().velocity_m_s[2] - cpu.bodies().velocity_m_s[2]), tol * norm(va_c));
      EXPECT_LT(worst_position_gap(cpu, gs), fixed ? 1e-12 : 1e-15);
      EXPECT_LT(norm(gs.bodies().angular_velocity_rad_s[0] - cpu.bodies().angular_velocity_rad_s[0]),
                (fixed ? 1e-9 : 1e-12) * (1.0 + norm(cpu.bodies().angular_velocity_rad_s[0])));
    }
  std::printf("[measured] list guard: %llu stops over %llu scenes, each following the CPU engine\n",
              static_cast<unsigned long long>(stops), static_cast<unsigned long long>(scenes));
}

// The same beads with BIODEM_GPU_LIST_GUARD=0 (no guard; for comparisons of speed): the list
// check finds a bead past half the skin at positions the list gave forces at and stops the run,
// naming the displacement (the rule before the guard; mutant 42).
TEST(GpuEngine, WithoutTheGuardASphereOutrunningTheListCheckStopsTheRun) {
  for (const char* queued : {"1", "0"}) {
    SCOPED_TRACE(std::string("BIODEM_GPU_QUEUED_CHECK=") + queued);
    SimSetup su = bead_setup(0.5, 0.3);
    sim::Simulation gs = make_simulation(su);
    add_particle(gs, 0, {-0.85e-3, 0, 0});
    add_particle(gs, 0, {0.85e-3, 0, 0});
    gs.set_skin(1e-7);
    ::setenv("BIODEM_GPU_LIST_GUARD", "0", 1);
    auto eng = gpu_engine_checks(gs, queued);
    ::unsetenv("BIODEM_GPU_LIST_GUARD");
    eng->upload();
    try {
      eng->advance(200);
      FAIL() << "without the guard, a sphere past half the skin at positions the list gave forces at must stop the run";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("more than half the skin"), std::string::npos) << what;
      EXPECT_NE(what.find("contacts may have been missed"), std::string::npos) << what;
    }
    EXPECT_EQ(eng->guard_stops(), 0u);
  }
  {  // a value other than 0 or 1: one line naming the switch
    SimSetup su = bead_setup(0.5, 0.3);
    sim::Simulation gs = make_simulation(su);
    ::setenv("BIODEM_GPU_LIST_GUARD", "off", 1);
    try {
      gpu_engine(gs);
      ADD_FAILURE() << "BIODEM_GPU_LIST_GUARD=off must be refused";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("BIODEM_GPU_LIST_GUARD = 'off': expected 0 or 1"), std::string::npos)
          << e.what();
    }
    ::unsetenv("BIODEM_GPU_LIST_GUARD");
  }
  // And a new list made between two checks at the positions of now must not hide it: a removal's
  // upload (a third bead inside a sink, removal test at step 10), a download with the history
  // after 10 steps (a checkpoint, or the end of a run), and a download without it then an upload.
  // The run stops there as the next check would have (mutants 46, 48).
  for (const char* mode : {"removal", "checkpoint", "upload"})
    for (const char* queued : {"1", "0"}) {
      SCOPED_TRACE(std::string(mode) + ", BIODEM_GPU_QUEUED_CHECK=" + queued);
      const bool sink = std::string(mode) == "removal";
      SimSetup su = bead_setup(0.5, 0.3);
      sim::Simulation gs = make_simulation(su);
      add_particle(gs, 0, {-0.85e-3, 0, 0});
      add_particle(gs, 0, {0.85e-3, 0, 0});
      if (sink) {
        sim::SinkSpec k;
        k.point_m = {0.0, -5e-3, 0.0};
        gs.add_sink(k);
        add_particle(gs, 0, {0, -10e-3, 0});
      }
      gs.set_skin(1e-7);
      ::setenv("BIODEM_GPU_LIST_GUARD", "0", 1);
      auto eng = gpu_engine_checks(gs, queued);
      ::unsetenv("BIODEM_GPU_LIST_GUARD");
      eng->upload();
      if (!sink) {
        ASSERT_EQ(eng->advance(10).steps, 10u) << "no check stops the run by step 10";
      }
      try {
        if (sink) {
          eng->advance(10);
        } else {
          const bool checkpoint = std::string(mode) == "checkpoint";
          eng->download(checkpoint);
          if (!checkpoint) eng->upload();
        }
        ADD_FAILURE() << "a new list must not hide a sphere past half the skin at positions the list gave forces at";
      } catch (const Error& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("more than half the skin (5e-08 m)"), std::string::npos) << what;
        EXPECT_NE(what.find("contacts may have been missed"), std::string::npos) << what;
      }
      EXPECT_EQ(eng->removal_uploads(), 0u);
    }
}

// The same beads, and a new list made between two checks at the positions of now: a removal's
// upload (a third bead inside a sink, removal test at step 10), a download with the history after
// 10 steps (a checkpoint, or the end of a run: the host list a resume and the last outputs go on
// from), and that download then an upload (an insertion wave's). The beads pass half the
// skin before step 10: the guard stops the device there and the advance ends with the steps
// made, so the new list is made at positions within half the skin of the device's list (before
// the guard, the run stopped; before that, the new list hid the passage and the run went on
// without a word). The run then goes on and follows the CPU engine.
TEST(GpuEngine, SphereOutrunningTheListBeforeANewListFollowsCpu) {
  for (const char* mode : {"removal", "checkpoint", "upload"})
    for (const char* queued : {"1", "0"}) {
      SCOPED_TRACE(std::string(mode) + ", BIODEM_GPU_QUEUED_CHECK=" + queued);
      const bool sink = std::string(mode) == "removal";
      SimSetup su = bead_setup(0.5, 0.3);
      sim::Simulation cpu = make_simulation(su), gs = make_simulation(su);
      for (auto* s : {&cpu, &gs}) {
        add_particle(*s, 0, {-0.85e-3, 0, 0});
        add_particle(*s, 0, {0.85e-3, 0, 0});
        if (sink) {
          sim::SinkSpec k;
          k.point_m = {0.0, -5e-3, 0.0};
          s->add_sink(k);
          add_particle(*s, 0, {0, -10e-3, 0});
        }
        s->set_skin(1e-7);
      }
      auto eng = gpu_engine_checks(gs, queued);
      eng->upload();
      for (int q = 0; q < 10; ++q) cpu.step();
      ASSERT_EQ(eng->advance(10).steps, 10u);
      if (!sink) {
        eng->download(true);
        if (std::string(mode) == "upload") eng->upload();
      }
      for (int q = 0; q < 150; ++q) cpu.step();
      ASSERT_EQ(eng->advance(150).steps, 150u);
      eng->download(true);
      EXPECT_GT(eng->guard_stops(), 0u);
      if (sink) {
        EXPECT_EQ(eng->removal_uploads(), 1u) << "the removal test of step 10 removed the third bead";
      }
      ASSERT_EQ(gs.bodies().size(), 2u);
      const Vec3 va_c = cpu.bodies().velocity_m_s[0], va_g = gs.bodies().velocity_m_s[0];
      EXPECT_LT(va_c.x, -0.5);
      EXPECT_LT(norm(va_g - va_c), 1e-12 * norm(va_c));
      EXPECT_LT(worst_position_gap(cpu, gs), 1e-15);
    }
}

// Translating walls (bulk tests: the heap's lifted cylinder, the shear box's gate). A plate
// scheduled to move from t = 0.2 ms to 1.2 ms at 1 m/s along +x starts 0.5 mm from a bead at rest
// (beyond its reach, radius + skin, at every list build before it moves: only the translating
// wall's rule makes it the bead's candidate) and strikes it; a second, disc-shaped wall starts
// moving later, from the run driver's call (start_wall_translation + sync_walls, as a lift
// phase), and lifts a bead resting on it against gravity. The GPU engine's walls follow the device clock
// (MoveWalls): the beads' trajectories and the walls' final places are the CPU engine's, to
// 1e-12 and exactly.
namespace {
/// A 10 mm square plate at x = -3 mm facing +x, moving at 1 m/s along +x from start_s to 1.2 ms.
sim::WallSpec moving_plate(double start_s) {
  sim::WallSpec plate = plane_wall({-3.0e-3, 5.0e-3, 0.0}, {1, 0, 0});
  plate.geometry.kind = walls::Kind::Rectangle;
  plate.geometry.edge_u = {0, 1, 0};
  plate.geometry.half_u_m = plate.geometry.half_v_m = 5e-3;
  plate.translation_velocity_m_s = {1.0, 0.0, 0.0};
  plate.move_start_s = start_s;
  plate.move_end_s = 1.2e-3;
  return plate;
}
}  // namespace

TEST(GpuEngine, TranslatingWallsMoveAsOnCpu) {
  for (bool entries : {true, false}) {
  SCOPED_TRACE(entries ? "per-contact kernels (wall-slot list)" : "row walk (every wall)");
  SimSetup su = bead_setup(0.5, 0.3);
  su.gravity_m_s2 = {0, -9.81, 0};
  sim::Simulation cpu = make_simulation(su), gs = make_simulation(su);
  for (auto* s : {&cpu, &gs}) {
    s->add_wall(moving_plate(2e-4));
    sim::WallSpec disc = plane_wall({0.0, -10e-3, 0.0}, {0, 1, 0});
    disc.geometry.kind = walls::Kind::Disc;
    disc.geometry.radius_m = 4e-3;
    s->add_wall(disc);
    add_particle(*s, 0, {-1.5e-3, 5.0e-3, 0.0});           // struck by the plate
    add_particle(*s, 0, {0.0, -10e-3 + 0.9995e-3, 0.0});  // resting on the disc
  }
  auto eng = gpu_engine(gs);
  eng->set_entry_forces(entries);
  eng->upload();
  const std::uint64_t steps = 8000, run = 53;
  for (std::uint64_t k = 0; k < steps; k += run) {
    const std::uint64_t n = std::min(run, steps - k);
    if (k == 4028) {  // the disc starts rising at 0.2 m/s for 0.6 ms (the driver's lift phase)
      for (auto* s : {&cpu, &gs}) s->start_wall_translation(1, {0.0, 0.2, 0.0}, s->time_s(), s->time_s() + 6e-4);
      eng->sync_walls();
    }
    for (std::uint64_t q = 0; q < n; ++q) cpu.step();
    ASSERT_EQ(eng->advance(n).steps, n);
  }
  eng->download(true);
  const Vec3 v0c = cpu.bodies().velocity_m_s[0], v0g = gs.bodies().velocity_m_s[0];
  const Vec3 v1c = cpu.bodies().velocity_m_s[1], v1g = gs.bodies().velocity_m_s[1];
  std::printf("[measured] struck bead v_x cpu %.9g gpu %.9g; lifted bead y cpu %.9g gpu %.9g m\n", v0c.x, v0g.x,
              cpu.bodies().position_m[1].y, gs.bodies().position_m[1].y);
  // The plate moved 1 mm and stopped 1 mm short of the bead's start: the bead was struck
  // (restitution 0.5 against a wall at 1 m/s: about 1.5 m/s), then flew on.
  EXPECT_GT(v0c.x, 1.2);
  // The disc rose 0.12 mm at 0.2 m/s and stopped; the bead rode on it and flew on (a disc that
  // did not move would have let it settle, a few tenths of a micrometre lower).
  EXPECT_GT(cpu.bodies().position_m[1].y, -10e-3 + 0.9995e-3 + 1.1e-4);
  EXPECT_LT(norm(v0g - v0c), 1e-12 * norm(v0c));
  EXPECT_LT(norm(v1g - v1c), 1e-12 * norm(v1c) + 1e-18);
  EXPECT_LT(worst_position_gap(cpu, gs), 1e-15);
  for (std::size_t w = 0; w < 2; ++w) {
    EXPECT_EQ(gs.walls()[w].geometry.point_m.x, cpu.walls()[w].geometry.point_m.x) << "wall " << w;
    EXPECT_EQ(gs.walls()[w].geometry.point_m.y, cpu.walls()[w].geometry.point_m.y) << "wall " << w;
  }
  EXPECT_EQ(gs.walls()[0].geometry.point_m.x, -3.0e-3 + 1e-3);
  }
}

// The translating walls with list guard stops: the scene above with the skin at 0.1 um and the
// overlapping pair of the guard tests 20 mm away along z, pushing apart while the plate moves
// (from t = 0 here) and again later when the struck bead takes off; the halted steps neither move
// the device clock nor the walls (MoveWalls reads the guard), so after each stop the walls are
// where the CPU engine's are and both beads follow the CPU engine.
TEST(GpuEngine, GuardStopsWithTranslatingWallsFollowCpu) {
  for (int family = 0; family < 3; ++family)
    for (const char* queued : {"1", "0"}) {
      SCOPED_TRACE(std::string(family == 0 ? "default" : family == 1 ? "row walk" : "row walk with the body update") +
                   ", BIODEM_GPU_QUEUED_CHECK=" + queued);
      SimSetup su = bead_setup(0.5, 0.3);
      su.gravity_m_s2 = {0, -9.81, 0};
      sim::Simulation cpu = make_simulation(su), gs = make_simulation(su);
      for (auto* s : {&cpu, &gs}) {
        s->add_wall(moving_plate(0.0));
        add_particle(*s, 0, {-1.5e-3, 5.0e-3, 0.0});  // struck by the plate at 0.5 ms
        add_particle(*s, 0, {-0.85e-3, 0, 20e-3});    // the overlapping pair
        add_particle(*s, 0, {0.85e-3, 0, 20e-3});
        s->set_skin(1e-7);
      }
      auto eng = gpu_engine_checks(gs, queued);
      eng->set_entry_forces(family == 0);
      if (family == 2) eng->set_walk_kick(true);
      eng->upload();
      const std::uint64_t steps = 4000, run = 53;
      for (std::uint64_t k = 0; k < steps; k += run) {
        const std::uint64_t n = std::min(run, steps - k);
        for (std::uint64_t q = 0; q < n; ++q) cpu.step();
        ASSERT_EQ(eng->advance(n).steps, n);
      }
      eng->download(true);
      std::printf("[measured] %s: %llu guard stops, plate x cpu %.9g gpu %.9g m\n", queued,
                  static_cast<unsigned long long>(eng->guard_stops()), cpu.walls()[0].geometry.point_m.x,
                  gs.walls()[0].geometry.point_m.x);
      EXPECT_GT(eng->guard_stops(), 0u);
      EXPECT_GT(cpu.bodies().velocity_m_s[0].x, 1.2) << "the plate struck the bead";
      EXPECT_EQ(gs.walls()[0].geometry.point_m.x, cpu.walls()[0].geometry.point_m.x);
      for (std::size_t b = 0; b < 3; ++b) {
        const Vec3 vc = cpu.bodies().velocity_m_s[b], vg = gs.bodies().velocity_m_s[b];
        EXPECT_LT(norm(vg - vc), 1e-12 * norm(vc)) << "body " << b;
      }
      EXPECT_LT(worst_position_gap(cpu, gs), 1e-15);
    }
}

// Sinks (SPEC 10): two beads fall from rest, one over a plate, one beside it into a sink below.
// The GPU engine removes the second at a list check after its centre crossed the sink plane
// (the CPU engine: after the drift that took it there), so the bead on the plate is untouched
// and matches the CPU engine's to round-off, with the same count and mass removed. The plate
// rises slowly meanwhile: the translating walls' device clock is kept across the removal's
// upload (a step off would put the plate 10 nm off, and the bead with it).
TEST(GpuEngine, SinkRemovesBodiesAsOnCpu) {
  SimSetup su = bead_setup(0.5, 0.3);
  su.gravity_m_s2 = {0, -9.81, 0};
  su.dt_s = 1e-6;
  sim::Simulation cpu = make_simulation(su), gs = make_simulation(su);
  for (auto* s : {&cpu, &gs}) {
    sim::WallSpec plate = plane_wall({0.0, 0.0, 0.0}, {0, 1, 0});
    plate.geometry.kind = walls::Kind::Disc;
    plate.geometry.radius_m = 3e-3;
    plate.translation_velocity_m_s = {0.0, 0.01, 0.0};  // rising while the other bead is removed
    plate.move_start_s = 5e-3;
    plate.move_end_s = 35e-3;
    s->add_wall(plate);
    sim::SinkSpec k;
    k.point_m = {0.0, -2e-3, 0.0};
    k.normal = {0, 1, 0};
    s->add_sink(k);
    add_particle(*s, 0, {0.0, 1.5e-3, 0.0});
    add_particle(*s, 0, {10e-3, 1.5e-3, 0.0});
  }
  auto eng = gpu_engine(gs);
  eng->upload();
  // 40 ms: the second bead falls 3.5 mm (to the sink plane) in about 26.7 ms. Runs of 997 steps
  // (the sink tests fall anywhere in a run, at its first and last steps too); the step at which
  // each engine removed the bead is found from the body count after every run.
  std::uint64_t cpu_removed_at = 0, done = 0;
  std::vector<std::uint64_t> gpu_counts;
  while (done < 40000) {
    const std::uint64_t n = std::min<std::uint64_t>(997, 40000 - done);
    for (std::uint64_t q = 0; q < n; ++q) {
      cpu.step();
      if (!cpu_removed_at && cpu.bodies().size() == 1) cpu_removed_at = done + q + 1;
    }
    ASSERT_EQ(eng->advance(n).steps, n);
    done += n;
    eng->download(false);
    gpu_counts.push_back(gs.bodies().size());
  }
  ASSERT_GT(cpu_removed_at, 0u);
  // The GPU engine removed it at the first step numbered a multiple of 10 from the CPU
  // engine's: the run holding that step is the first with one body.
  const std::uint64_t gpu_step = (cpu_removed_at + 9) / 10 * 10;
  for (std::size_t r = 0; r < gpu_counts.size(); ++r)
    EXPECT_EQ(gpu_counts[r], (r + 1) * 997 >= gpu_step ? 1u : 2u) << "run " << r;
  std::printf("[measured] the CPU engine removed the bead at step %llu, the GPU engine by step %llu\n",
              static_cast<unsigned long long>(cpu_removed_at), static_cast<unsigned long long>(gpu_step));
  eng->download(true);
  ASSERT_EQ(cpu.bodies().size(), 1u);
  ASSERT_EQ(gs.bodies().size(), 1u);
  EXPECT_EQ(gs.removed_bodies(), 1u);
  EXPECT_EQ(gs.removed_mass_kg(), cpu.removed_mass_kg());
  EXPECT_EQ(gs.bodies().id[0], cpu.bodies().id[0]);
  EXPECT_LT(norm(gs.bodies().position_m[0] - cpu.bodies().position_m[0]), 1e-15);
  EXPECT_LT(norm(gs.bodies().velocity_m_s[0] - cpu.bodies().velocity_m_s[0]), 1e-12);
}

TEST(GpuEngine, StaticOverlapOnPlane) {
  SimSetup su = bead_setup(0.3, 0.5);
  su.gravity_m_s2 = {0, -9.81, 0};
  su.dt_s = 1e-6;
  sim::Simulation gs = make_simulation(su);
  gs.add_wall(plane_wall({0, 0, 0}, {0, 1, 0}));
  add_particle(gs, 0, {0, 1e-3, 0});
  auto eng = gpu_engine(gs);
  eng->upload();
  for (int k = 0; k < 40000; ++k) eng->step();
  eng->download(true);
  const double r = 1e-3, m = sphere_mass_kg(r, su.particle.density_kg_m3);
  const double y_eff = effective_young_pa(su.particle, su.wall);
  const double expected = hertz_static_overlap_m(m * 9.81, r, y_eff);
  const double measured = r - gs.bodies().position_m[0].y;
  report("gpu engine static overlap (m)", measured, expected);
  EXPECT_NEAR(measured, expected, 0.01 * expected);
}

// Torque-free tumbling of an asymmetric clump (the free-rotor splitting): same orientation and
// spin as the CPU engine, lab angular momentum conserved.
TEST(GpuEngine, ClumpTumblingMatchesCpu) {
  SimSetup su = bead_setup(0.5, 0.3);
  su.templates = {clump_template({{0, 0, 0}, {0.8e-3, 0, 0}, {0, 0.5e-3, 0.3e-3}}, {0.5e-3, 0.4e-3, 0.3e-3})};
  su.dt_s = 1e-5;
  sim::Simulation cpu = make_simulation(su), gs = make_simulation(su);
  for (auto* s : {&cpu, &gs}) add_particle(*s, 0, {0, 0, 0}, {0.01, 0, 0}, {30, 5, -12});
  auto eng = gpu_engine(gs);
  eng->upload();
  const Vec3 l0 = gs.angular_momentum_about_origin();
  run_pair(cpu, *eng, 5000);
  const Quat qc = cpu.bodies().orientation[0], qg = gs.bodies().orientation[0];
  if (backend_under_test() == gpu::Backend::HostThreads) {
    EXPECT_EQ(std::memcmp(&qc, &qg, sizeof(Quat)), 0) << "no contact: the integration is the same arithmetic";
  } else {  // a GPU's sin and cos are not glibc's: last-bit differences
    const double dq = std::abs(qc.w - qg.w) + std::abs(qc.x - qg.x) + std::abs(qc.y - qg.y) + std::abs(qc.z - qg.z);
    EXPECT_LT(dq, 1e-12);
  }
  const Vec3 l1 = gs.angular_momentum_about_origin();
  std::printf("[measured] clump tumbling: |dL|/|L| = %.3g\n", norm(l1 - l0) / norm(l0));
  EXPECT_LT(norm(l1 - l0), 1e-12 * norm(l0));
}

namespace {

/// A random packing of spheres (two sizes) and needles in a turning cylinder with a periodic
/// axis: every slot of the contact model and every branch of the neighbour list.
std::unique_ptr<sim::Simulation> packing(double skin_m = -1.0, bool walls = true, bool gravity = true,
                                         bool spheres_only = false, bool tangential_reduce = false) {
  constexpr double kRc = 20e-3, kLz = 12e-3, kSpacing = 3e-3;
  config::Shape needle;
  needle.name = "needle";
  needle.kind = config::ShapeKind::Needle;
  needle.d50_m = 1.0e-3;
  needle.aspect_ratio = 0.4;
  needle.overlap_factor = 0.2;
  SimSetup su;
  su.particle = {5e6, 0.3, 1000.0};
  su.wall = {5e6, 0.3, 0.0};
  su.particle_particle = {0.5, 0.5, 0.3, 5e4};
  su.particle_wall = {0.5, 0.4, 0.5, 2.5e4};
  su.templates = {sphere_template(0.6e-3), sphere_template(0.45e-3), shapes::make_template(needle, 1.0)};
  su.dt_s = 1e-5;
  su.gravity_m_s2 = gravity ? Vec3{0, -9.81, 0} : Vec3{};
  su.tangential_reduce = tangential_reduce;
  auto s = std::make_unique<sim::Simulation>(make_simulation(su));
  if (walls) s->add_wall(cylinder_wall({0, 0, 0}, {0, 0, 1}, kRc, 3.0));
  neighbor::Domain d;
  d.periodic = {false, false, true};
  d.lo_m = {0, 0, 0};
  d.hi_m = {0, 0, kLz};
  s->set_domain(d);
  if (skin_m > 0.0) s->set_skin(skin_m);
  std::mt19937_64 gen(2024);
  const int n = static_cast<int>(kRc / kSpacing);
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j)
      for (int l = 0; l < static_cast<int>(kLz / kSpacing); ++l) {
        const Vec3 x{i * kSpacing, j * kSpacing, (l + 0.5) * kSpacing};
        if (std::hypot(x.x, x.y) > kRc - 2.5e-3) continue;
        const auto shape = static_cast<std::uint32_t>(gen() % (spheres_only ? 2 : 3));
        const Quat q = normalized(Quat{uniform(gen) - 0.5, uniform(gen) - 0.5, uniform(gen) - 0.5, uniform(gen) - 0.5});
        const Vec3 v{uniform(gen) - 0.5, uniform(gen) - 0.5, uniform(gen) - 0.5};
        const Vec3 w{200 * (uniform(gen) - 0.5), 200 * (uniform(gen) - 0.5), 200 * (uniform(gen) - 0.5)};
        add_particle(*s, shape, x, 2.0 * v, w, q);
      }
  return s;
}

}  // namespace

// Image shifts are stored in 8 bits and positions are never wrapped: as the CPU list
// (VerletList.SphereTooManyPeriodsAwayIsAnError), the device list stops with a message once a
// sphere is more than 60 periodic lengths away, rather than give wrong pairs (before: no check,
// the shift silently wrapped). The packing (periodic along z, 12 mm) with one more sphere 200
// periods up.
TEST(GpuEngine, SphereTooManyPeriodsAwayIsAnError) {
  auto s = packing();
  add_particle(*s, 0, {1.5e-3, 1.5e-3, 200 * 12e-3 + 1.5e-3}, {0, 0, 0});
  auto e = gpu_engine(*s);
  try {
    e->upload();
    FAIL() << "no error";
  } catch (const Error& err) {
    EXPECT_NE(std::string(err.what()).find("periodic lengths away along axis 2"), std::string::npos) << err.what();
  }
  // 50 periods away is within the 8 bits: it runs.
  auto t = packing();
  add_particle(*t, 0, {1.5e-3, 1.5e-3, 50 * 12e-3 + 1.5e-3}, {0, 0, 0});
  auto f = gpu_engine(*t);
  f->upload();
  f->advance(20);
}

// A sphere far away on a bounded axis coarsens the neighbour cells (at most ~4 per sphere): the
// periodic axis (12 mm) keeps 3 cells however coarse the cells of the other axes become (before:
// "periodic length ... shorter than 3 neighbour cells" once a sphere was ~0.5 m away, on both
// engines), and however far the sphere (up to 1e9 m) the cell keys stay within 32 bits (before,
// the device grid stopped coarsening after 64 steps and its cell count could overflow an int).
// The packing without its cylinder (a sphere outside it would be a wall contact) and one sphere
// x away, 200 steps on each engine: the same positions to round-off.
TEST(GpuEngine, SphereFarAwayKeepsTheListWorking) {
  for (const double x : {0.5, 1e3, 1e9}) {
    auto t = packing(-1.0, false), c = packing(-1.0, false);
    add_particle(*t, 0, {x, 1.5e-3, 1.5e-3}, {0, 0, 0});
    add_particle(*c, 0, {x, 1.5e-3, 1.5e-3}, {0, 0, 0});
    auto f = gpu_engine(*t);
    f->upload();
    EXPECT_EQ(f->advance(200).steps, 200u);
    f->download(true);
    for (int k = 0; k < 200; ++k) c->step();
    EXPECT_LT(worst_position_gap(*t, *c), 1e-9) << x << " m away";
    EXPECT_GT(t->contact_count(), 3u);  // (contacts in the packing, evaluated alike)
  }
}

// The device list holds exactly the pairs of spheres of different bodies closer than
// r_i + r_j + skin (periodic minimum image), each pair in both spheres' rows. Scene: 1,200
// bodies (spheres of two sizes and needles) at random positions in a box periodic along z.
TEST(GpuEngine, NeighbourListEqualsBruteForce) {
  auto s = packing(0.4e-3);
  {
    sim::Simulation& sim = *s;
    std::mt19937_64 gen(99);
    for (int k = 0; k < 1200; ++k) {
      const Vec3 x{16e-3 * (uniform(gen) - 0.5), 16e-3 * (uniform(gen) - 0.5), 9e-3 * uniform(gen) + 1e-3};
      const Quat q = normalized(Quat{uniform(gen) - 0.5, uniform(gen) - 0.5, uniform(gen) - 0.5, uniform(gen) - 0.5});
      add_particle(sim, static_cast<std::uint32_t>(gen() % 3), x, {}, {}, q);
    }
  }
  auto eng = gpu_engine(*s);
  eng->upload();
  const auto& sp = s->spheres();
  const double skin = s->skin_m();
  std::vector<std::pair<std::uint32_t, std::uint32_t>> ref;
  const Vec3 len = s->domain().length_m();
  for (std::uint32_t i = 0; i < sp.size(); ++i)
    for (std::uint32_t j = i + 1; j < sp.size(); ++j) {
      if (sp.body[i] == sp.body[j]) continue;
      Vec3 d = sp.position_m[i] - sp.position_m[j];
      d.z -= len.z * std::round(d.z / len.z);
      const double c = sp.radius_m[i] + sp.radius_m[j] + skin;
      if (norm2(d) < c * c) ref.emplace_back(i, j);
    }
  std::size_t unmirrored = 1;
  const auto got = eng->list_pairs(&unmirrored);
  std::printf("[measured] device list: %zu pairs (brute force %zu), skin %.3g m\n", got.size(), ref.size(), skin);
  ASSERT_GT(skin, 0.0);
  ASSERT_GT(ref.size(), 500u);
  EXPECT_EQ(unmirrored, 0u);
  EXPECT_TRUE(got == ref);
}

// The dense packing (needles, cohesion, rolling friction, a turning cylinder, a periodic axis,
// list rebuilds) stepped 300 times by both engines, under each friction rule (the default, cohesion
// kept out of the limits, and tangential_reduce): bodies agree to 1e-9 m.
TEST(GpuEngine, DensePackingMatchesCpu) {
  for (const bool reduce : {false, true}) {  // both friction rules (cohesive bed: CED 5e4, walls 2.5e4)
    SCOPED_TRACE(reduce ? "tangential_reduce" : "default rule");
    auto cpu = packing(-1.0, true, true, false, reduce), gs = packing(-1.0, true, true, false, reduce);
    auto eng = gpu_engine(*gs);
    eng->upload();
    std::size_t contacts = 0;
    for (int k = 0; k < 300; ++k) {
      cpu->step();
      eng->step();
      contacts += cpu->contact_count();
    }
    eng->download(true);
    const double gap = worst_position_gap(*cpu, *gs);
    std::printf("[measured] dense packing: %zu bodies, %zu contact-steps, %llu device builds, worst |dx| = %.3g m, "
                "KE cpu %.9g gpu %.9g, contacts cpu %zu gpu %zu\n",
                cpu->bodies().size(), contacts, static_cast<unsigned long long>(eng->list_builds()), gap,
                cpu->kinetic_energy_j(), gs->kinetic_energy_j(), cpu->contact_count(), gs->contact_count());
    EXPECT_GT(contacts, 1000u);
    EXPECT_GT(eng->list_builds(), 1u);
    EXPECT_LT(gap, 1e-9);
    EXPECT_NEAR(gs->kinetic_energy_j(), cpu->kinetic_energy_j(), 1e-6 * cpu->kinetic_energy_j());
    EXPECT_EQ(gs->contact_count(), cpu->contact_count());
  }
}

// In a scene of single-sphere bodies the body kernels place each sphere at its body's centre
// without loading its offset, but only when every offset is zero (Engine::centred_spheres_, at
// upload). A template's single sphere always sits at its body's centre, so here every other
// sphere is moved off it by hand (10 um along the body's x axis, the body moved back so that the
// sphere stays where it was) on both engines: the GPU engine must place them by their offsets as
// the CPU engine does (spheres placed at their bodies' centres would change their contacts'
// overlaps by up to 20 um and the packing's motion far beyond the tolerance).
TEST(GpuEngine, OffCentreSingleSphereIsPlacedByItsOffset) {
  auto cpu = packing(0.5e-3, true, true, true), gs = packing(0.5e-3, true, true, true);
  ASSERT_EQ(cpu->spheres().size(), cpu->bodies().size());
  for (auto* sim : {cpu.get(), gs.get()})
    for (std::size_t k = 0; k < sim->bodies().size(); k += 2) {
      const std::uint32_t i = sim->bodies().first_sphere[k];
      sim->spheres_mut().offset_body_m[i] = Vec3{1e-5, 0.0, 0.0};
      sim->bodies_mut().position_m[k] -= rotate(sim->bodies().orientation[k], Vec3{1e-5, 0.0, 0.0});
    }
  auto eng = gpu_engine(*gs);
  eng->upload();
  for (int k = 0; k < 200; ++k) {
    cpu->step();
    eng->step();
  }
  eng->advance(200);
  for (int k = 0; k < 200; ++k) cpu->step();
  eng->download(true);
  const double gap = worst_position_gap(*cpu, *gs);
  std::printf("[measured] off-centre single sphere: %zu bodies, worst |dx| = %.3g m after 400 steps\n",
              cpu->bodies().size(), gap);
  EXPECT_LT(gap, 1e-9);
}

// Without walls and gravity, in a periodic box, total momentum is conserved: each pair's two
// forces are exact opposites (mirrored evaluation), so only the summation round-off remains.
TEST(GpuEngine, MomentumConservedAcrossPeriodicBoundary) {
  auto gs = packing(-1.0, false, false);
  auto eng = gpu_engine(*gs);
  eng->upload();
  eng->download(false);
  const Vec3 p0 = gs->linear_momentum();
  double scale = 0.0;
  for (std::size_t b = 0; b < gs->bodies().size(); ++b) scale += gs->bodies().mass_kg[b] * norm(gs->bodies().velocity_m_s[b]);
  for (int k = 0; k < 400; ++k) eng->step();
  eng->download(false);
  const Vec3 p1 = gs->linear_momentum();
  std::printf("[measured] periodic momentum drift |dp| / sum m|v| = %.3g\n", norm(p1 - p0) / scale);
  EXPECT_LT(norm(p1 - p0), 1e-12 * scale);
}

// The GPU engine's result does not depend on when its list is rebuilt (a different skin, a check
// every step or every 10 steps with a displacement margin) nor on the number of threads:
// bit-identical states. This is what makes a GPU run resume bit for bit.
TEST(GpuEngine, ResultIndependentOfSkinAndThreads) {
  auto run = [](double skin, int threads, std::uint32_t check_every) {
    const ScopedThreads scoped(threads);
    // Small scene: lower the threshold so that the kernels really run on the OpenMP threads.
    struct Threshold {
      std::size_t old = kParallelThreshold;
      Threshold() { set_parallel_threshold(0); }
      ~Threshold() { set_parallel_threshold(old); }
    } threshold;
    auto s = packing(skin);
    auto eng = gpu_engine(*s);
    eng->set_check_every(check_every);
    eng->upload();
    for (int k = 0; k < 200; ++k) eng->step();
    eng->download(false);
    return std::make_pair(s->bodies().position_m, eng->list_builds());
  };
  const auto a = run(0.25e-3, 1, 1), b = run(0.6e-3, 2, 10), c = run(0.25e-3, 1, 10);
  std::printf("[measured] device builds: skin 0.25 mm checked every step %llu, skin 0.6 mm every 10 steps %llu, "
              "skin 0.25 mm every 10 steps %llu\n",
              static_cast<unsigned long long>(a.second), static_cast<unsigned long long>(b.second),
              static_cast<unsigned long long>(c.second));
  EXPECT_NE(a.second, b.second) << "the runs must rebuild at different steps for the test to mean anything";
  EXPECT_NE(a.second, c.second);
  ASSERT_EQ(a.first.size(), b.first.size());
  EXPECT_EQ(std::memcmp(a.first.data(), b.first.data(), a.first.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(std::memcmp(a.first.data(), c.first.data(), a.first.size() * sizeof(Vec3)), 0);
}

// The list check reads the motion (largest displacement since the build, largest speed) that the
// steps before it queued on the device one step before their end, so the host does not wait for
// the device at a check that does not rebuild; it then allows for that step in its margin. The
// packing with a 1.2 mm skin (spheres at up to ~1.7 m/s, ~17 um per step: most checks do not
// rebuild, so the motion read decides), stepped in runs of varied length: after every run each
// pair of spheres that touches is in the device list, and almost every check read a queued
// motion (all but the first after each upload). It fails when the queued motion goes stale
// (checked: not queued after the first 50 steps).
TEST(GpuEngine, ListChecksReadTheQueuedMotionAndMissNoContact) {
  auto s = packing(1.2e-3);
  auto eng = gpu_engine(*s);
  eng->upload();
  const std::uint64_t runs[] = {1, 9, 10, 11, 37, 64, 3, 150, 2, 113};
  std::uint64_t steps = 0, touching_seen = 0;
  for (const std::uint64_t r : runs) {
    eng->advance(r);
    steps += r;
    eng->download(false);
    std::size_t unmirrored = 1;
    const auto list = eng->list_pairs(&unmirrored);
    EXPECT_EQ(unmirrored, 0u);
    const auto& sp = s->spheres();
    const Vec3 len = s->domain().length_m();
    std::size_t missing = 0;
    for (std::uint32_t i = 0; i < sp.size(); ++i)
      for (std::uint32_t j = i + 1; j < sp.size(); ++j) {
        if (sp.body[i] == sp.body[j]) continue;
        Vec3 d = sp.position_m[i] - sp.position_m[j];
        d.z -= len.z * std::round(d.z / len.z);
        const double c = sp.radius_m[i] + sp.radius_m[j];
        if (!(norm2(d) < c * c)) continue;
        ++touching_seen;
        if (!std::binary_search(list.begin(), list.end(), std::make_pair(i, j))) ++missing;
      }
    EXPECT_EQ(missing, 0u) << "after " << steps << " steps";
  }
  const std::uint64_t waitless = eng->waitless_list_checks();
  std::printf("[measured] %llu steps, %llu list builds, %llu checks read a queued motion, %llu touching pairs "
              "seen, all in the list\n",
              static_cast<unsigned long long>(steps), static_cast<unsigned long long>(eng->list_builds()),
              static_cast<unsigned long long>(waitless), static_cast<unsigned long long>(touching_seen));
  EXPECT_GT(touching_seen, 0u);
  EXPECT_GT(eng->list_builds(), 3u);
  EXPECT_GE(waitless, steps / 10 - 2);  // at least one check per 10 steps, the first one waited
}

// Checkpoint round trip between engines: the GPU state downloaded with its history into the
// host, continued on the CPU engine, matches the GPU engine continuing itself (1e-9 m after 200
// more steps; the summation order differs), and an upload of the downloaded state continues the
// GPU run bit for bit.
TEST(GpuEngine, HistoryRoundTripBetweenEngines) {
  auto a = packing(), b = packing();
  auto ea = gpu_engine(*a), eb = gpu_engine(*b);
  ea->upload();
  eb->upload();
  for (int k = 0; k < 150; ++k) {
    ea->step();
    eb->step();
  }
  eb->download(true);  // b's host now holds the full state; continue b on the device after a re-upload
  auto c = packing();
  eb->download(true);
  // c: a third copy, continued on the CPU from b's downloaded state.
  c->bodies_mut() = b->bodies();
  c->wall_contacts() = b->wall_contacts();
  c->neighbor_list_mut() = b->neighbor_list();
  c->spheres_mut() = b->spheres();
  c->restore_after_checkpoint(b->time_s(), b->step_count(), b->drum_rotating(), b->skin_m(),
                              b->neighbor_list().built_at(), b->neighbor_list().builds());
  eb->upload();
  for (int k = 0; k < 200; ++k) {
    ea->step();
    eb->step();
    c->step();
  }
  ea->download(false);
  eb->download(false);
  EXPECT_EQ(std::memcmp(a->bodies().position_m.data(), b->bodies().position_m.data(),
                        a->bodies().size() * sizeof(Vec3)),
            0)
      << "download + upload must not perturb the GPU run";
  const double gap = worst_position_gap(*a, *c);
  std::printf("[measured] GPU state continued on the CPU engine: worst |dx| = %.3g m after 200 steps\n", gap);
  EXPECT_LT(gap, 1e-9);
}

// "lab" rolling convention at a turning wall (LIGGGHTS 3.8.0): a sphere rolling round the inside
// of a turning cylinder with EPSD2 and cohesion, 2,000 steps on both engines.
TEST(GpuEngine, LabWallRollingMatchesCpu) {
  SimSetup su = bead_setup(0.3, 0.5, 0.5, 1e4);
  su.gravity_m_s2 = {0, -9.81, 0};
  su.dt_s = 1e-6;
  sim::Simulation cpu = make_simulation(su), gs = make_simulation(su);
  for (auto* s : {&cpu, &gs}) {
    s->add_wall(cylinder_wall({0, 0, 0}, {0, 0, 1}, 10e-3, 3.0));
    s->set_wall_rolling_lab(true);
    add_particle(*s, 0, {0, -9.0e-3, 0}, {0.01, 0, 0}, {0, 0, 5});
  }
  auto eng = gpu_engine(gs);
  eng->upload();
  run_pair(cpu, *eng, 2000);
  const Vec3 wc = cpu.bodies().angular_velocity_rad_s[0], wg = gs.bodies().angular_velocity_rad_s[0];
  std::printf("[measured] lab rolling: w_z cpu %.12g gpu %.12g, |dx| = %.3g m\n", wc.z, wg.z, worst_position_gap(cpu, gs));
  EXPECT_LT(norm(wg - wc), 1e-12 * norm(wc));
  EXPECT_LT(worst_position_gap(cpu, gs), 1e-15);
}

// Issue 17 item 2: walls of every kind on the emulated kernels, serially (the default threshold
// of 2,048 indices keeps this scene's kernels on one thread) and in parallel (threshold 0, two
// OpenMP threads). Up to 150 cohesive beads (d 0.8 mm) with EPSD2 (mu_r 0.2, CED 2e4) thrown at
// 0.6 m/s onto a disc (y = 0, radius 8 mm), into an open tube (finite cylinder, radius 3 mm, 6 mm
// tall, standing on the disc) and onto a tilted rectangle beside it; gravity -y, 2,000 steps of
// 5e-6 s (10 % of the Rayleigh time). The two
// emulated runs must be bit-identical (each kernel index computes independently; the sums are
// in a fixed order), and both must follow the CPU engine to 1e-9 m.
namespace {
std::string first_difference(const sim::Simulation& a, const sim::Simulation& b);  // (below)
}  // namespace

TEST(GpuEngine, WallsOfEveryKindSeriallyAndInParallel) {
  auto scene = []() {
    SimSetup su = bead_setup(0.2, 0.4, 0.2, 2e4);
    su.templates = {sphere_template(0.4e-3)};
    su.dt_s = 5e-6;
    su.gravity_m_s2 = {0, -9.81, 0};
    auto s = std::make_unique<sim::Simulation>(make_simulation(su));
    s->set_skin(0.4e-3);  // half a diameter: fast beads, checks every 10 steps on the device
    sim::WallSpec disc = plane_wall({0, 0, 0}, {0, 1, 0});
    disc.geometry.kind = walls::Kind::Disc;
    disc.geometry.radius_m = 8e-3;
    s->add_wall(disc);
    sim::WallSpec tube = cylinder_wall({0, 0, 0}, {0, 1, 0}, 3e-3, 0.0);
    tube.geometry.length_m = 6e-3;
    s->add_wall(tube);
    sim::WallSpec rect = plane_wall({6e-3, 0.8e-3, 0}, {-0.3, 1, 0});
    rect.geometry.kind = walls::Kind::Rectangle;
    rect.geometry.edge_u = normalized(Vec3{1, 0.3, 0});
    rect.geometry.half_u_m = 2.5e-3;
    rect.geometry.half_v_m = 4e-3;
    s->add_wall(rect);
    std::mt19937_64 g(17);
    for (int k = 0; k < 150; ++k) {
      const bool in_tube = k < 60;
      const double x = in_tube ? -2e-3 + 4e-3 * uniform(g) : 3.6e-3 + 4.8e-3 * uniform(g);
      const double z = in_tube ? -2e-3 + 4e-3 * uniform(g) : -3.5e-3 + 7e-3 * uniform(g);
      const double y = in_tube ? 0.45e-3 + 4e-3 * uniform(g) : 2.5e-3 + 3e-3 * uniform(g);
      bool free = true;
      for (std::size_t b = 0; b < s->bodies().size() && free; ++b)
        free = norm(s->bodies().position_m[b] - Vec3{x, y, z}) > 0.85e-3;
      if (free) add_particle(*s, 0, {x, y, z}, {0, -0.6, 0});
    }
    return s;
  };
  // (the GPU runs also update their walls every 250 steps, between list builds, as a phase start
  // does: the wall-slot list is then made again from the positions of the last build)
  auto run_gpu = [&](bool parallel, bool full_pass = false) {
    const ScopedThreads scoped(parallel ? 2 : 1);
    const std::size_t old = kParallelThreshold;
    if (parallel) set_parallel_threshold(0);
    auto s = scene();
    if (full_pass) ::setenv("BIODEM_GPU_PAIR_LIST", "full", 1);
    auto eng = gpu_engine(*s);
    ::unsetenv("BIODEM_GPU_PAIR_LIST");
    eng->set_entry_forces(true);
    eng->upload();
    for (int k = 0; k < 2000; ++k) {
      eng->step();
      if (k % 250 == 249) eng->sync_walls();
    }
    eng->download(true);
    set_parallel_threshold(old);
    return s;
  };
  auto cpu = scene();
  std::size_t most_contacts = 0;
  {
    const ScopedThreads one(1);
    for (int k = 0; k < 2000; ++k) {
      cpu->step();
      most_contacts = std::max(most_contacts, cpu->contact_count());
    }
  }
  const auto serial = run_gpu(false), parallel = run_gpu(true), full = run_gpu(false, true);
  ASSERT_EQ(serial->bodies().size(), parallel->bodies().size());
  // the wall-slot list (the slots within reach of a disc's rim, a tube's ends, a rectangle's
  // edges) against every slot: the same bits
  EXPECT_EQ(first_difference(*serial, *full), "") << "the pass over every wall slot";
  const auto& a = serial->bodies().position_m;
  const auto& b = parallel->bodies().position_m;
  const double gap = worst_position_gap(*cpu, *serial);
  std::size_t on_rect = 0, in_tube = 0;  // beads resting on each wall kind at the end
  for (const Vec3& x : cpu->bodies().position_m) {
    if (std::hypot(x.x, x.z) < 3e-3 && x.y < 1e-3) ++in_tube;
    if (x.x > 3.6e-3 && x.y > 0.8e-3) ++on_rect;
  }
  std::printf("[measured] walls of every kind: %zu beads (%zu low in the tube, %zu above the disc's level by the "
              "rectangle), %zu contacts at the end, %zu at most (CPU); serial vs parallel emulation %s, the wall-slot "
              "list vs every slot compared above; worst |dx| vs the CPU engine %.3g m\n",
              cpu->bodies().size(), in_tube, on_rect, cpu->contact_count(), most_contacts,
              std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3)) == 0 ? "bit-identical" : "DIFFERENT", gap);
  EXPECT_GT(cpu->bodies().size(), 60u);
  EXPECT_GT(most_contacts, 20u);  // the beads landed and touch walls and each other (measured 32)
  EXPECT_GT(in_tube, 10u);  // measured 20
  EXPECT_GT(on_rect, 5u);  // measured 38
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3)), 0);
  EXPECT_LT(gap, 1e-9);
  EXPECT_EQ(serial->contact_count(), cpu->contact_count());
}

// The settle criterion evaluated on the device (DeviceEngine::begin_settle / advance): the phase
// ends at the step where the run driver's rule, applied one step at a time on the host to the
// same engine's kinetic energy (what the driver did before the criterion moved to the device),
// ends it; the state there is bit-identical whatever the length of the runs of steps; the steps
// after it do nothing; after end_settle the engine steps on as before, bit for bit. The CPU
// engine's criterion ends the phase at the same step (its kinetic energy differs in the last
// bits only). Scene: 120 beads thrown onto a plane, settling.
TEST(GpuEngine, SettleCriterionOnTheDeviceEndsAtTheHostStep) {
  auto scene = [] {
    SimSetup su = bead_setup(0.1, 0.5, 0.5);
    su.templates = {sphere_template(0.5e-3)};
    su.dt_s = 1e-5;
    su.gravity_m_s2 = {0, -9.81, 0};
    auto s = std::make_unique<sim::Simulation>(make_simulation(su));
    s->add_wall(plane_wall({0, 0, 0}, {0, 1, 0}));
    std::mt19937_64 g(5);
    for (int i = 0; i < 12; ++i)
      for (int l = 0; l < 10; ++l) {
        const Vec3 x{(i - 5.5) * 1.2e-3, 0.7e-3 + 0.2e-3 * uniform(g), (l - 4.5) * 1.2e-3};
        add_particle(*s, 0, x, {0.02 * (uniform(g) - 0.5), 0.0, 0.02 * (uniform(g) - 0.5)});
      }
    return s;
  };
  for (const bool translational : {false, true}) {
    gpu::DeviceEngine::SettleCriterion c;
    c.threshold_j = 2e-12;
    c.translational = translational;
    c.min_steps = 200;
    c.hold_steps = 100;
    const std::uint64_t max_steps = 30000;
    auto met = [&](std::uint64_t k, std::uint64_t below) { return k >= c.min_steps && below >= c.hold_steps; };
    // The host rule, one step at a time.
    auto ref = scene();
    auto er = gpu_engine(*ref);
    er->upload();
    std::uint64_t k_ref = 0, below_ref = 0;
    while (!met(k_ref, below_ref) && k_ref < max_steps) {
      er->step();
      ++k_ref;
      const double ke = translational ? er->translational_kinetic_energy_j() : er->kinetic_energy_j();
      below_ref = ke / static_cast<double>(ref->bodies().size()) < c.threshold_j ? below_ref + 1 : 0;
    }
    er->download(false);
    // The CPU engine with the same rule.
    auto cpu = scene();
    std::uint64_t k_cpu = 0, below_cpu = 0;
    {
      const ScopedThreads one(1);
      cpu->refresh();
      while (!met(k_cpu, below_cpu) && k_cpu < max_steps) {
        cpu->step();
        ++k_cpu;
        const double ke = translational ? cpu->translational_kinetic_energy_j() : cpu->kinetic_energy_j();
        below_cpu = ke / static_cast<double>(cpu->bodies().size()) < c.threshold_j ? below_cpu + 1 : 0;
      }
    }
    std::printf("[measured] settle criterion (%s): host rule on the GPU engine ends at step %llu, CPU engine at %llu\n",
                translational ? "translational" : "total", static_cast<unsigned long long>(k_ref),
                static_cast<unsigned long long>(k_cpu));
    ASSERT_TRUE(met(k_ref, below_ref)) << "the scene must settle within max_steps for the test to mean anything";
    EXPECT_GT(k_ref, 2 * c.min_steps);
    EXPECT_EQ(k_cpu, k_ref);
    for (const std::uint64_t run : {1ull, 7ull, 37ull, 200ull}) {
      auto s = scene();
      auto e = gpu_engine(*s);
      e->upload();
      e->begin_settle(c, 0, 0);
      std::uint64_t k = 0, below = 0, calls = 0;
      bool settled = false;
      while (!settled && k < max_steps) {
        const auto a = e->advance(std::min(run, max_steps - k));
        ASSERT_GT(a.steps, 0u);
        ASSERT_TRUE(a.steps == std::min(run, max_steps - k) || a.settled) << "a run stops early only when settled";
        k += a.steps;
        below = a.below;
        settled = a.settled;
        ++calls;
      }
      EXPECT_EQ(k, k_ref) << "runs of " << run;
      EXPECT_EQ(below, below_ref) << "runs of " << run;
      EXPECT_EQ(s->step_count(), ref->step_count());
      EXPECT_EQ(s->time_s(), ref->time_s());
      // Settled: a further run does nothing.
      EXPECT_EQ(e->advance(10).steps, 0u);
      e->download(false);
      const auto& xa = s->bodies().position_m;
      const auto& xr = ref->bodies().position_m;
      const auto& va = s->bodies().velocity_m_s;
      const auto& vr = ref->bodies().velocity_m_s;
      ASSERT_EQ(xa.size(), xr.size());
      EXPECT_EQ(std::memcmp(xa.data(), xr.data(), xa.size() * sizeof(Vec3)), 0) << "runs of " << run;
      EXPECT_EQ(std::memcmp(va.data(), vr.data(), va.size() * sizeof(Vec3)), 0) << "runs of " << run;
      if (run == 37) {
        // After the phase the engine steps again, as the engine stepped one step at a time.
        e->end_settle();
        auto r2 = scene();
        auto e2 = gpu_engine(*r2);
        e2->upload();
        for (std::uint64_t q = 0; q < k_ref + 50; ++q) e2->step();
        EXPECT_EQ(e->advance(50).steps, 50u);
        e->download(false);
        e2->download(false);
        EXPECT_EQ(std::memcmp(s->bodies().position_m.data(), r2->bodies().position_m.data(), xa.size() * sizeof(Vec3)), 0);
        EXPECT_EQ(s->step_count(), r2->step_count());
        std::printf("[measured] runs of %llu steps: %llu calls for %llu steps\n", static_cast<unsigned long long>(run),
                    static_cast<unsigned long long>(calls), static_cast<unsigned long long>(k));
      }
    }
  }
}

namespace {

/// Everything of two host states that a GPU run leaves behind after download(true), compared
/// byte for byte: the bodies' state and forces, the spheres' forces, the contact count, the host
/// list's pair history and the wall history. Empty when equal, else the first difference.
template <class T>
bool same_bytes(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}
std::string first_difference(const sim::Simulation& a, const sim::Simulation& b) {
  const auto &ba = a.bodies(), &bb = b.bodies();
  if (!same_bytes(ba.position_m, bb.position_m)) return "body positions";
  if (!same_bytes(ba.velocity_m_s, bb.velocity_m_s)) return "body velocities";
  if (!same_bytes(ba.angular_velocity_rad_s, bb.angular_velocity_rad_s)) return "body angular velocities";
  if (!same_bytes(ba.angular_momentum_kg_m2_s, bb.angular_momentum_kg_m2_s)) return "body angular momenta";
  if (!same_bytes(ba.orientation, bb.orientation)) return "body orientations";
  if (!same_bytes(ba.force_n, bb.force_n)) return "body forces";
  if (!same_bytes(ba.torque_n_m, bb.torque_n_m)) return "body torques";
  if (!same_bytes(a.spheres().force_n, b.spheres().force_n)) return "sphere forces";
  if (!same_bytes(a.spheres().torque_n_m, b.spheres().torque_n_m)) return "sphere torques";
  if (a.contact_count() != b.contact_count()) return "contact counts";
  if (!same_bytes(a.neighbor_list().j, b.neighbor_list().j)) return "host list pairs";
  if (!same_bytes(a.neighbor_list().touching, b.neighbor_list().touching)) return "pair touching flags";
  if (!same_bytes(a.neighbor_list().history, b.neighbor_list().history)) return "pair history";
  if (!same_bytes(a.wall_contacts().start, b.wall_contacts().start) ||
      !same_bytes(a.wall_contacts().wall, b.wall_contacts().wall) ||
      !same_bytes(a.wall_contacts().touching, b.wall_contacts().touching))
    return "wall contacts";
  if (!same_bytes(a.wall_contacts().history, b.wall_contacts().history)) return "wall history";
  if (a.step_count() != b.step_count() || a.time_s() != b.time_s()) return "clock";
  return "";
}

}  // namespace

// Two engines over two copies of a scene, stepped alike in runs of 37, 1, 113, 8, 64, 29 and 200
// steps (452 in all) across list checks and rebuilds, with a settle-criterion phase that does not
// end over runs 3 and 4 and, when `upload_after_run_4`, both engines uploaded again from their
// host state after run 4 (a checkpoint resumed): the two hosts' state, forces and history must be
// bit-identical after every run. Returns the steps made.
std::uint64_t step_alike_in_runs(gpu::DeviceEngine& ea, gpu::DeviceEngine& eb, const sim::Simulation& a,
                                 const sim::Simulation& b, bool upload_after_run_4, std::size_t* most_contacts = nullptr) {
  gpu::DeviceEngine::SettleCriterion never;
  never.threshold_j = 0.0;
  never.min_steps = 1000000;
  const std::uint64_t runs[] = {37, 1, 113, 8, 64, 29, 200};
  std::uint64_t steps = 0;
  for (std::size_t r = 0; r < std::size(runs); ++r) {
    if (r == 3) {
      ea.begin_settle(never, 0, 0);
      eb.begin_settle(never, 0, 0);
    }
    if (r == 5) {
      ea.end_settle();
      eb.end_settle();
    }
    EXPECT_EQ(ea.advance(runs[r]).steps, runs[r]);
    EXPECT_EQ(eb.advance(runs[r]).steps, runs[r]);
    steps += runs[r];
    ea.download(true);
    eb.download(true);
    if (most_contacts) *most_contacts = std::max(*most_contacts, a.contact_count());
    const std::string diff = first_difference(a, b);
    EXPECT_EQ(diff, "") << "after run " << r << " (" << steps << " steps)";
    if (!diff.empty()) break;
    if (r == 4 && upload_after_run_4) {
      ea.upload();
      eb.upload();
    }
  }
  return steps;
}

/// Two copies of the packing (skin, spheres only or not), each with its own engine set up by
/// `set_a` / `set_b` before the upload, stepped alike in runs (step_alike_in_runs).
struct SteppedAlike {
  std::unique_ptr<sim::Simulation> a, b;
  std::unique_ptr<gpu::DeviceEngine> ea, eb;
  std::uint64_t steps = 0;
};
template <class SetA, class SetB>
SteppedAlike stepped_alike(double skin_m, bool spheres_only, bool upload_after_run_4, SetA set_a, SetB set_b) {
  SteppedAlike r;
  r.a = packing(skin_m, true, true, spheres_only);
  r.b = packing(skin_m, true, true, spheres_only);
  r.ea = gpu_engine(*r.a);
  r.eb = gpu_engine(*r.b);
  set_a(*r.ea);
  set_b(*r.eb);
  r.ea->upload();
  r.eb->upload();
  r.steps = step_alike_in_runs(*r.ea, *r.eb, *r.a, *r.b, upload_after_run_4);
  return r;
}

// Between two list checks, outside a settle-criterion phase, the body reduction of step c and
// the first half of step c + 1 run as one kernel (ReduceKickDrift). The dense packing, stepped
// in runs of steps (advance) across many list checks and rebuilds, with a criterion phase in the
// middle (there the separate kernels run, the kinetic energy sum and the criterion's update sit
// between them): the fused engine's state is bit-identical to the unfused engine's, after every
// run. (On CUDA the fused launches are the ones captured in the graphs.)
TEST(GpuEngine, FusedReduceKickDriftGivesTheBitsOfTheSeparateKernels) {
  // A skin of 1.2 mm: list checks several steps apart (runs of fused launches between them).
  const auto r = stepped_alike(
      1.2e-3, false, false, [](gpu::DeviceEngine& e) { e.set_fused_kick(true); },
      [](gpu::DeviceEngine& e) { e.set_fused_kick(false); });
  const auto& ea = r.ea;
  const auto& eb = r.eb;
  const std::uint64_t steps = r.steps;
  std::printf("[measured] fused vs separate kernels: %llu steps in 7 runs, %llu list builds, %llu steps fused "
              "(separate engine: %llu); state, forces and history bit-identical after every run\n",
              static_cast<unsigned long long>(steps),
              static_cast<unsigned long long>(ea->list_builds()), static_cast<unsigned long long>(ea->fused_steps()),
              static_cast<unsigned long long>(eb->fused_steps()));
  EXPECT_GT(ea->list_builds(), 5u);
  EXPECT_EQ(ea->list_builds(), eb->list_builds());
  EXPECT_GT(ea->fused_steps(), steps / 2);
  EXPECT_EQ(eb->fused_steps(), 0u);
  EXPECT_EQ(ea->sums_in_kick_steps(), 0u);  // the packing has needles: the sums stay in SumEntries
}

// PairEntries evaluates each pair once, from its lower-id side, and advances the pair's history
// in that side's entry only; the row walk (Forces) reads both sides' entries. Switching from the
// entry kernels to the row walk in the middle of a run (and back) hands the history over
// (MirrorHistory): the packing stepped with entries, rows, entries and rows again in turn is
// bit-identical, after each row-walk run, to the packing stepped with the row walk throughout
// (compared there only, so that nothing but the switch stands between an entry run and the row
// walk). It fails when the history is not copied to the other side's entry (checked).
TEST(GpuEngine, EntryKernelsHandTheHistoryToTheRowWalk) {
  auto a = packing(0.5e-3), b = packing(0.5e-3);
  auto ea = gpu_engine(*a), eb = gpu_engine(*b);
  ea->set_entry_forces(true);
  eb->set_entry_forces(false);
  ea->upload();
  eb->upload();
  const std::uint64_t runs[] = {151, 97, 203, 64};
  std::uint64_t steps = 0;
  for (std::size_t r = 0; r < std::size(runs); ++r) {
    ea->set_entry_forces(r % 2 == 0);
    EXPECT_EQ(ea->advance(runs[r]).steps, runs[r]);
    EXPECT_EQ(eb->advance(runs[r]).steps, runs[r]);
    steps += runs[r];
    if (r % 2 == 0) continue;  // compared after the row-walk runs: nothing but the switch between
    ea->download(true);
    eb->download(true);
    const std::string diff = first_difference(*a, *b);
    EXPECT_EQ(diff, "") << "after run " << r << " (" << steps << " steps)";
    if (!diff.empty()) break;
  }
  EXPECT_EQ(ea->entry_force_passes(), runs[0] + runs[2]);
  EXPECT_GT(a->contact_count(), 0u);  // (contacts with history at the switches: the test fails without the copy)
}

// BIODEM_GPU_FORCES=timed (the default on a GPU): after each upload the runs of steps between
// list checks go through the scene's candidate sets (in this scene of clumps eleven: the entry
// kernels, also with their sums by the row lanes; the row walk with the row lanes; in one thread
// per sphere, alone, with the warp's touching contacts shared (also by 2 and, since 4 threads per
// sphere fit in one wave of an H100, 4 lanes per sphere), with the body kernel by lanes; with the
// body update by groups of lanes per body,
// ForcesKickDriftGroups, also shared), timed, those far slower dropped after one run; the
// fastest runs on.
// Each switch from the entry kernels to the row walk hands over the history (the row walk reads
// both entries of a pair). The packing stepped that way, with an upload (a new round of trials)
// in the middle, is bit-identical after every run to the packing stepped with the row walk
// throughout. (It fails without the hand-over at the trial switches: checked.)
TEST(GpuEngine, TimedKernelChoiceHandsTheHistoryOverBetweenTrials) {
  auto a = packing(0.5e-3), b = packing(0.5e-3);
  ::setenv("BIODEM_GPU_FORCES", "timed", 1);
  auto ea = gpu_engine(*a);
  ::unsetenv("BIODEM_GPU_FORCES");
  auto eb = gpu_engine(*b);
  eb->set_entry_forces(false);
  ea->set_check_every(3);  // short runs between checks: the trials end early in each part
  eb->set_check_every(3);
  ea->upload();
  eb->upload();
  const std::uint64_t steps = step_alike_in_runs(*ea, *eb, *a, *b, true);
  const std::string how = ea->contact_kernels();
  std::printf("[measured] timed choice: %llu steps, %llu by the entry kernels; %s\n",
              static_cast<unsigned long long>(steps), static_cast<unsigned long long>(ea->entry_force_passes()),
              how.c_str());
  EXPECT_NE(how.find("when the sets were last timed, over "), std::string::npos) << how;
  EXPECT_NE(how.find("(2 choice(s) in the run:"), std::string::npos) << how;  // one per upload
  EXPECT_GT(ea->entry_force_passes(), 0u);
  EXPECT_LT(ea->entry_force_passes(), steps);
}

// The timed choice times its sets again at each phase start (retime_kernels, which the driver
// calls) and after every so many steps of the chosen set (set_retime_every; 20,000 by default),
// since the bed it first timed them on (as inserted) can differ from the bed later. Each new
// timing switches sets for its trials (and hands the history over); the packing stepped so,
// with re-timings every 60 steps and one asked for, is bit-identical after every run to the
// packing stepped with the row walk throughout, and makes more choices than the 2 uploads'.
// (Without the packed walks and the body kernel by lanes, five sets: a timing takes at most 20
// runs of at most 3 steps whatever is dropped, so the count of choices below does not depend on
// the host's timings.)
TEST(GpuEngine, TimedKernelChoiceIsTimedAgainAtPhasesAndPeriodically) {
  // (spheres: the walk with the row lanes and the walk in one thread with the body update,
  // ForcesKickDrift; needles: the one-thread walk with it, ForcesKickDriftGroups)
  for (const bool spheres_only : {false, true}) {
    SCOPED_TRACE(spheres_only ? "spheres" : "needles");
    auto a = packing(0.5e-3, true, true, spheres_only), b = packing(0.5e-3, true, true, spheres_only);
    ::setenv("BIODEM_GPU_FORCES", "timed", 1);
    ::setenv("BIODEM_GPU_WALK_PACK", "0", 1);
    ::setenv("BIODEM_GPU_BODY_LANES", "1", 1);
    auto ea = gpu_engine(*a);
    ::unsetenv("BIODEM_GPU_FORCES");
    ::unsetenv("BIODEM_GPU_WALK_PACK");
    ::unsetenv("BIODEM_GPU_BODY_LANES");
    auto eb = gpu_engine(*b);
    eb->set_entry_forces(false);
    ea->set_check_every(3);
    eb->set_check_every(3);
    ea->set_retime_every(60);
    ea->upload();
    eb->upload();
    ea->retime_kernels();  // (under way after the upload: no second restart)
    const std::uint64_t steps = step_alike_in_runs(*ea, *eb, *a, *b, true);
    const std::string how = ea->contact_kernels();
    std::printf("[measured] re-timed choice: %llu steps; %s\n", static_cast<unsigned long long>(steps), how.c_str());
    // 452 steps, an upload at 223; a timing takes about 60 steps (20 runs between list checks
    // of at most 3): choices at about 60 and 180 (timed again after 60 steps of the first), 285
    // (after the upload) and 405: 4 choices, where without the re-timings there are 2 (the test
    // above).
    int choices = 0;
    const auto at = how.find(" choice(s) in the run");
    ASSERT_NE(at, std::string::npos) << how;
    const auto digits = how.find_last_not_of("0123456789", at - 1);
    ASSERT_EQ(std::sscanf(how.c_str() + digits + 1, "%d", &choices), 1) << how;
    EXPECT_GE(choices, 4) << how;
    // retime_kernels after a choice starts a new timing at once
    ea->set_retime_every(1000000);
    EXPECT_EQ(ea->advance(60).steps, 60u);  // (the timing under way ends)
    EXPECT_EQ(eb->advance(60).steps, 60u);
    ASSERT_EQ(ea->contact_kernels().find("under way"), std::string::npos) << ea->contact_kernels();
    ea->retime_kernels();
    EXPECT_NE(ea->contact_kernels().find("the timing of the sets is under way"), std::string::npos)
        << ea->contact_kernels();
    EXPECT_EQ(ea->advance(100).steps, 100u);
    EXPECT_EQ(eb->advance(100).steps, 100u);
    ea->download(true);
    eb->download(true);
    EXPECT_EQ(first_difference(*a, *b), "");
    // (the trials of the sets with the body update ran ForcesKickDrift, or ForcesKickDriftGroups
    // in the scene of clumps)
    EXPECT_GT(ea->walk_kick_steps(), 0u);
  }
}

// In a scene of single-sphere bodies the fused steps also sum each sphere's contacts inside the
// body kernel (SumEntriesKickDrift, one launch fewer per step). The packing with spheres only
// (two sizes; cohesion, rolling friction, a turning cylinder, a periodic axis), stepped in runs
// across list checks, rebuilds and a criterion phase: bit-identical after every run to the
// engine launching SumEntries, ReduceKick and KickDriftSpheres apart, and to the row walk.
TEST(GpuEngine, SumsInsideTheKickGiveTheBitsOfSumEntries) {
  for (const bool entries_b : {true, false}) {
    const auto r = stepped_alike(
        1.2e-3, true, true,
        [](gpu::DeviceEngine& e) {
          e.set_fused_kick(true);
          e.set_entry_forces(true);
        },
        [entries_b](gpu::DeviceEngine& e) {
          e.set_fused_kick(false);
          e.set_entry_forces(entries_b);
        });
    const auto& ea = r.ea;
    const auto& eb = r.eb;
    const std::uint64_t steps = r.steps;
    std::printf("[measured] sums in the body kernel vs %s: %llu steps, %llu with the sums in the body kernel, "
                "%llu list builds; bit-identical after every run\n",
                entries_b ? "SumEntries + ReduceKick + KickDriftSpheres" : "the row walk",
                static_cast<unsigned long long>(steps), static_cast<unsigned long long>(ea->sums_in_kick_steps()),
                static_cast<unsigned long long>(ea->list_builds()));
    EXPECT_GT(ea->sums_in_kick_steps(), steps / 2);
    EXPECT_EQ(ea->sums_in_kick_steps(), ea->fused_steps());
    EXPECT_EQ(eb->sums_in_kick_steps(), 0u);
    EXPECT_GT(ea->list_builds(), 5u);
  }
}

// The row walk and the body update run as one kernel (BIODEM_GPU_WALK_KICK): in a scene of
// single spheres ForcesKickDrift, in a scene of clumps ForcesKickDriftGroups (a group of lanes
// per body; on CPU threads one lane walks the body's spheres, then updates the body). Each
// thread reads the neighbours' motion from one buffer and writes its spheres' new motion to the
// other, the two swapped every step, the motion copied back after an odd number of steps. The
// packing of spheres (two sizes) and the packing of needles and beads (clumps of 1 to 3
// spheres; cohesion, rolling friction, a turning cylinder, a periodic axis), stepped in runs of
// odd and even lengths across list checks, rebuilds, a criterion phase (unfused there) and an
// upload: bit-identical after every run to the walk and ReduceKickDrift apart, and to the entry
// kernels (with the sums in the body kernel for the spheres); the first comparison of each
// scene with the kernels on two OpenMP threads (threshold 0). (Read and written in one buffer,
// as the walk and the update in place, it differs: checked for the spheres, and for the clumps
// by the sums read from the buffer the spheres are placed in.)
TEST(GpuEngine, WalkWithTheBodyUpdateGivesTheBitsOfTheWalkAndReduceKickDrift) {
  for (const bool spheres_only : {true, false})
    for (const bool entries_b : {false, true}) {
      // (the first on the OpenMP threads, threshold 0, where a read of a neighbour the same
      // kernel updates would be a race; the second serially)
      const ScopedThreads scoped(entries_b ? 1 : 2);
      const std::size_t old = kParallelThreshold;
      if (!entries_b) set_parallel_threshold(0);
      const auto r = stepped_alike(
          1.2e-3, spheres_only, true,
          [](gpu::DeviceEngine& e) {
            e.set_entry_forces(false);
            e.set_walk_kick(true);
          },
          [entries_b](gpu::DeviceEngine& e) {
            e.set_entry_forces(entries_b);
            e.set_walk_kick(false);
          });
      set_parallel_threshold(old);
      std::printf("[measured] row walk with the body update (%s) vs %s: %llu steps, %llu with the update in the "
                  "walk, %llu list builds; bit-identical after every run\n",
                  spheres_only ? "spheres" : "clumps",
                  entries_b ? "the entry kernels" : "the row walk and ReduceKickDrift",
                  static_cast<unsigned long long>(r.steps), static_cast<unsigned long long>(r.ea->walk_kick_steps()),
                  static_cast<unsigned long long>(r.ea->list_builds()));
      EXPECT_GT(r.ea->walk_kick_steps(), r.steps / 2);
      EXPECT_EQ(r.ea->walk_kick_steps(), r.ea->fused_steps());
      EXPECT_EQ(r.eb->walk_kick_steps(), 0u);
      EXPECT_GT(r.ea->list_builds(), 5u);
      // (the list checks read the motion from the buffer that holds it: the same rebuilds)
      EXPECT_EQ(r.ea->list_builds(), r.eb->list_builds());
      const std::string how = r.ea->contact_kernels();
      EXPECT_NE(how.find(spheres_only ? "(ForcesKickDrift)" : "in groups of 4 lanes per body (ForcesKickDriftGroups"),
                std::string::npos)
          << how;
    }
}

// The entry kernels' per-sphere sums as a row walk (SumEntriesWalk; in single-sphere scenes
// SumEntriesKickDriftWalk), on CPU threads by one thread per sphere (on CUDA shared by the row
// lanes; test_group_lanes.cpp covers the lanes): bit-identical after every run to SumEntries and
// SumEntriesKickDrift, in the packing of needles and in the packing of spheres (the sums inside
// the body kernel), across list checks, rebuilds, a criterion phase and an upload.
TEST(GpuEngine, EntrySumsAsARowWalkGiveTheBitsOfSumEntries) {
  for (const bool spheres_only : {false, true}) {
    const auto r = stepped_alike(
        spheres_only ? 1.2e-3 : 0.5e-3, spheres_only, true,
        [](gpu::DeviceEngine& e) {
          e.set_entry_forces(true);
          e.set_sum_lanes(true);
        },
        [](gpu::DeviceEngine& e) {
          e.set_entry_forces(true);
          e.set_sum_lanes(false);
        });
    std::printf("[measured] entry sums as a row walk vs one thread per sphere (%s): %llu steps, %llu with the sums "
                "in the body kernel, %llu list builds; bit-identical after every run\n",
                spheres_only ? "spheres" : "needles", static_cast<unsigned long long>(r.steps),
                static_cast<unsigned long long>(r.ea->sums_in_kick_steps()),
                static_cast<unsigned long long>(r.ea->list_builds()));
    EXPECT_EQ(r.ea->entry_force_passes(), r.steps);
    EXPECT_GT(r.ea->list_builds(), 5u);
    if (spheres_only) {
      EXPECT_GT(r.ea->sums_in_kick_steps(), r.steps / 2);
    }
    const std::string how = r.ea->contact_kernels();
    EXPECT_NE(how.find("SumEntries by the "), std::string::npos) << how;
  }
}

// The contact forces as one thread per row entry and wall slot (PairEntries) and a per-sphere sum
// of the row and walls in order (SumEntries) against one thread per sphere walking its row and
// walls (Forces): the same operations in the same order, so the same bits. The 436-body packing (cohesion, rolling friction, a
// turning cylinder, a periodic axis), stepped in runs across list checks, rebuilds and a
// criterion phase, with a download and upload in the middle: state, forces, contact counts,
// pair and wall history bit-identical after every run.
TEST(GpuEngine, EntryForcesGiveTheBitsOfTheRowWalk) {
  const auto r = stepped_alike(
      0.5e-3, false, true, [](gpu::DeviceEngine& e) { e.set_entry_forces(true); },
      [](gpu::DeviceEngine& e) { e.set_entry_forces(false); });
  const auto& ea = r.ea;
  const auto& eb = r.eb;
  const std::uint64_t steps = r.steps;
  std::printf("[measured] entry kernels vs row walk: %llu steps, %llu list builds, %llu force passes by the "
              "entry kernels (row-walk engine: %llu); state, forces and history bit-identical after every run\n",
              static_cast<unsigned long long>(steps), static_cast<unsigned long long>(ea->list_builds()),
              static_cast<unsigned long long>(ea->entry_force_passes()),
              static_cast<unsigned long long>(eb->entry_force_passes()));
  EXPECT_EQ(ea->entry_force_passes(), steps);  // counted per step, graphs or not (an H100 run caught a count per graph capture)
  EXPECT_EQ(eb->entry_force_passes(), 0u);
  EXPECT_GT(ea->list_builds(), 5u);
}

// The bodies are stored on the device sorted by the cell of their first sphere (re-sorted at
// list builds), and everything indexed by body or sphere follows them; the results do not depend
// on it. The dense packing (bodies created on a lattice, x slowest: far from the list's cell order,
// so the sort permutes) on three engines: sorted at every build, at every 4th (the default) and
// never. Stepped in runs of steps across list checks and rebuilds, with a settle-criterion phase
// (the kinetic energy sum on the device) and a download and upload in the middle (a checkpoint
// resumed): state, forces, pair and wall history, kinetic energy and the device list's pairs
// (named by host index) bit-identical after every run.
TEST(GpuEngine, BodiesSortedByCellGiveTheBitsOfTheHostOrder) {
  auto a = packing(0.5e-3), b = packing(0.5e-3), c = packing(0.5e-3);
  auto ea = gpu_engine(*a), eb = gpu_engine(*b), ec = gpu_engine(*c);
  ea->set_sort_every(1);
  eb->set_sort_every(0);
  ec->set_sort_every(4);
  for (auto* e : {ea.get(), eb.get(), ec.get()}) e->upload();
  const std::vector<std::uint32_t> order = ea->body_order(), unsorted = eb->body_order();
  std::vector<std::uint32_t> identity(a->bodies().size());
  std::iota(identity.begin(), identity.end(), 0u);
  std::size_t moved = 0;
  for (std::size_t k = 0; k < order.size(); ++k) moved += order[k] != k;
  ASSERT_EQ(order.size(), identity.size());
  EXPECT_NE(order, identity) << "the scene must be out of cell order for the test to mean anything";
  EXPECT_EQ(unsorted, identity);
  {
    std::vector<std::uint32_t> seen = order;  // a permutation of the host's bodies
    std::sort(seen.begin(), seen.end());
    EXPECT_EQ(seen, identity);
  }
  EXPECT_EQ(ea->body_sorts(), 1u);
  std::size_t unmirrored = 1;
  EXPECT_EQ(ea->list_pairs(&unmirrored), eb->list_pairs(nullptr)) << "list pairs named by host index";
  EXPECT_EQ(unmirrored, 0u);
  gpu::DeviceEngine::SettleCriterion never;
  never.threshold_j = 0.0;
  never.min_steps = 1000000;
  const std::uint64_t runs[] = {37, 1, 113, 8, 64, 29, 200, 50};
  std::uint64_t steps = 0;
  for (std::size_t r = 0; r < std::size(runs); ++r) {
    if (r == 3)
      for (auto* e : {ea.get(), eb.get(), ec.get()}) e->begin_settle(never, 0, 0);
    if (r == 5)
      for (auto* e : {ea.get(), eb.get(), ec.get()}) e->end_settle();
    for (auto* e : {ea.get(), eb.get(), ec.get()}) ASSERT_EQ(e->advance(runs[r]).steps, runs[r]);
    steps += runs[r];
    EXPECT_EQ(ea->kinetic_energy_j(), eb->kinetic_energy_j());
    EXPECT_EQ(ec->translational_kinetic_energy_j(), eb->translational_kinetic_energy_j());
    for (auto* e : {ea.get(), eb.get(), ec.get()}) e->download(true);
    ASSERT_EQ(first_difference(*a, *b), "") << "sorted at every build, after run " << r << " (" << steps << " steps)";
    ASSERT_EQ(first_difference(*c, *b), "") << "sorted at every 4th build, after run " << r;
    if (r <= 6) {  // (later, the lists of the engines uploaded again were built at other steps)
      EXPECT_EQ(ea->list_pairs(nullptr), eb->list_pairs(nullptr)) << "after run " << r;
      EXPECT_EQ(ec->list_pairs(nullptr), eb->list_pairs(nullptr)) << "after run " << r;
    }
    if (r == 6) {
      EXPECT_NE(ea->body_order(), order) << "later sorts must reorder the bodies again for the test to mean anything";
      // A checkpoint resumed: the host state (host order) uploaded again and sorted afresh.
      ea->upload();
      ec->upload();
    }
  }
  std::printf("[measured] bodies sorted by cell: %zu of %zu bodies moved by the first sort; %llu steps, %llu list "
              "builds, %llu sorts reordered the bodies at every build, %llu at every 4th, %llu unsorted; state, "
              "forces, history bit-identical after every run\n",
              moved, order.size(), static_cast<unsigned long long>(steps),
              static_cast<unsigned long long>(eb->list_builds()), static_cast<unsigned long long>(ea->body_sorts()),
              static_cast<unsigned long long>(ec->body_sorts()), static_cast<unsigned long long>(eb->body_sorts()));
  EXPECT_GT(eb->list_builds(), 10u);
  EXPECT_GT(ea->body_sorts(), 5u);
  EXPECT_GT(ec->body_sorts(), 2u);
  EXPECT_LT(ec->body_sorts(), ea->body_sorts());
  EXPECT_EQ(eb->body_sorts(), 0u);
}

namespace {

/// Spheres of two sizes moving in a box periodic along all three axes, no walls, no gravity,
/// on a lattice 1.35 x 1.5 x 1.5 mm (no overlaps at the start). The box is 5.5 x 9 x 12 mm, or
/// 3.2 list cut-offs along an axis where that is more: at the skin of 0.5 mm it has 3 list cells
/// along x (so the cells before and after a sphere's along x are the two other cells, reached
/// round the axis), and along every axis at larger skins. The list's image shifts on every axis,
/// both ways.
std::unique_ptr<sim::Simulation> periodic_box(double skin_m) {
  SimSetup su;
  su.particle = {5e6, 0.3, 1000.0};
  su.wall = {5e6, 0.3, 0.0};
  su.particle_particle = {0.5, 0.5, 0.3, 5e4};
  su.particle_wall = {0.5, 0.4, 0.5, 2.5e4};
  su.templates = {sphere_template(0.6e-3), sphere_template(0.45e-3)};
  su.dt_s = 1e-5;
  su.gravity_m_s2 = Vec3{};
  auto s = std::make_unique<sim::Simulation>(make_simulation(su));
  const double cut = 1.2e-3 + skin_m;
  const Vec3 len{std::max(5.5e-3, 3.2 * cut), std::max(9e-3, 3.2 * cut), std::max(12e-3, 3.2 * cut)};
  const Vec3 spacing{1.35e-3, 1.5e-3, 1.5e-3};
  neighbor::Domain d;
  d.periodic = {true, true, true};
  d.lo_m = {-0.5 * len.x, 0, 0};
  d.hi_m = {0.5 * len.x, len.y, len.z};
  s->set_domain(d);
  s->set_skin(skin_m);
  std::mt19937_64 gen(77);
  const int nx = static_cast<int>(len.x / spacing.x), ny = static_cast<int>(len.y / spacing.y),
            nz = static_cast<int>(len.z / spacing.z);
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
      for (int l = 0; l < nz; ++l) {
        const Vec3 x{d.lo_m.x + (i + 0.5) * spacing.x, (j + 0.5) * spacing.y, (l + 0.5) * spacing.z};
        const auto shape = static_cast<std::uint32_t>(gen() % 2);
        const Vec3 v{uniform(gen) - 0.5, uniform(gen) - 0.5, uniform(gen) - 0.5};
        add_particle(*s, shape, x, 3.0 * v, {100 * (uniform(gen) - 0.5), 0, 0});
      }
  return s;
}

}  // namespace

// The list build by a group of lanes per sphere (BuildRowsGrouped, the default) gives the rows,
// lengths and carried history of the build by one thread per sphere (BuildRows): the same bits
// in every later state. On CPU threads the group is one lane (its candidate runs, staging, the
// placement by rank and the history by the old row's entries); on a GPU (BIODEM_TEST_GPU=1) 16
// lanes of a warp. Scenes: the packing (needles, a turning cylinder, periodic along z, sorts of
// the bodies, an upload in the middle), and the box periodic along x, y and z with 3 cells
// along x, at skins whose rows fit 16 entries, widen past 48 (where BuildRows builds in place)
// and past 128 (where the engine falls back to BuildRows). The list of the box against brute
// force. It fails when a run of cells loses a piece, a shift or a candidate (checked: dropping
// piece 1 of the x runs, or the shift of piece 0, makes the periodic box differ).
TEST(GpuEngine, GroupedListBuildGivesTheRowsOfBuildRows) {
  auto on = [](gpu::DeviceEngine& e) { e.set_grouped_list_build(true); };
  auto off = [](gpu::DeviceEngine& e) { e.set_grouped_list_build(false); };
  {
    const auto r = stepped_alike(0.5e-3, false, true, on, off);
    std::printf("[measured] grouped list build, packing: %llu steps, %llu builds (%llu grouped), %llu body sorts; "
                "state, forces, history bit-identical to BuildRows after every run\n",
                static_cast<unsigned long long>(r.steps), static_cast<unsigned long long>(r.ea->list_builds()),
                static_cast<unsigned long long>(r.ea->grouped_list_builds()),
                static_cast<unsigned long long>(r.ea->body_sorts()));
    EXPECT_EQ(r.ea->list_builds(), r.eb->list_builds());
    EXPECT_GT(r.ea->list_builds(), 3u);
    EXPECT_GT(r.ea->body_sorts(), 1u);
    EXPECT_EQ(r.ea->grouped_list_builds(), r.ea->list_builds());
    EXPECT_EQ(r.eb->grouped_list_builds(), 0u);
    EXPECT_EQ(r.ea->list_pairs(nullptr), r.eb->list_pairs(nullptr));
  }
  for (const double skin : {0.5e-3, 2.2e-3, 3.4e-3}) {
    auto a = periodic_box(skin), b = periodic_box(skin);
    auto ea = gpu_engine(*a), eb = gpu_engine(*b);
    on(*ea);
    off(*eb);
    ea->upload();
    eb->upload();
    const std::uint64_t steps = step_alike_in_runs(*ea, *eb, *a, *b, true);
    // Lists built afresh for the state now (an upload builds), against each other and brute force.
    ea->download(true);
    eb->download(true);
    ea->upload();
    eb->upload();
    std::size_t unmirrored = 1;
    const auto pairs = ea->list_pairs(&unmirrored);
    EXPECT_EQ(unmirrored, 0u);
    EXPECT_EQ(pairs, eb->list_pairs(nullptr));
    const auto& sp = a->spheres();
    const Vec3 len = a->domain().length_m();
    std::vector<std::pair<std::uint32_t, std::uint32_t>> ref;
    std::size_t across = 0;
    for (std::uint32_t i = 0; i < sp.size(); ++i)
      for (std::uint32_t j = i + 1; j < sp.size(); ++j) {
        if (sp.body[i] == sp.body[j]) continue;
        Vec3 dv = sp.position_m[i] - sp.position_m[j];
        bool wrapped = false;
        for (int k = 0; k < 3; ++k) {
          const double sh = std::round(dv[k] / len[k]);
          dv[k] -= len[k] * sh;
          wrapped = wrapped || (k == 0 && sh != 0.0);
        }
        const double c = sp.radius_m[i] + sp.radius_m[j] + a->skin_m();
        if (norm2(dv) < c * c) {
          ref.emplace_back(i, j);
          across += wrapped;
        }
      }
    std::printf("[measured] grouped list build, %zu spheres in a box periodic on 3 axes, skin %.2g mm: %llu steps, "
                "%llu builds (%llu grouped), row capacity %u; %zu pairs in the list of the last state (%zu across "
                "the x period), brute force %zu\n",
                sp.size(), 1e3 * skin, static_cast<unsigned long long>(steps),
                static_cast<unsigned long long>(ea->list_builds()),
                static_cast<unsigned long long>(ea->grouped_list_builds()), ea->row_capacity(), pairs.size(), across,
                ref.size());
    EXPECT_GT(ea->list_builds(), 2u);
    EXPECT_EQ(eb->grouped_list_builds(), 0u);
    EXPECT_GT(across, 10u) << "pairs must cross the x period for the test to mean anything";
    EXPECT_TRUE(pairs == ref);
    if (skin < 1e-3) {
      EXPECT_LE(ea->row_capacity(), 48u);
      EXPECT_EQ(ea->grouped_list_builds(), ea->list_builds());
    } else if (skin < 3e-3) {
      EXPECT_GT(ea->row_capacity(), 48u);
      EXPECT_LE(ea->row_capacity(), 128u);
      EXPECT_EQ(ea->grouped_list_builds(), ea->list_builds());
    } else {
      EXPECT_GT(ea->row_capacity(), 128u);  // the fallback to BuildRows
      EXPECT_LT(ea->grouped_list_builds(), ea->list_builds());
    }
  }
}

// A position that becomes non-finite stops the run with a message naming the sphere and its
// body and pointing at dt_s, not a run that goes on: one body of the packing given a NaN or an
// infinite velocity before the upload, stepped in runs, with the list checks reading the motion
// queued before them and waiting for it (BIODEM_GPU_QUEUED_CHECK=0). (The first check after an
// upload waits either way and finds it; a position that becomes non-finite after a queued
// motion was read is put in cell 0 by CellOf if a rebuild follows, and found by the next check.)
TEST(GpuEngine, NonFinitePositionStopsTheRunNamingTheSphere) {
  for (const double v : {std::nan(""), HUGE_VAL})
    for (const bool queued : {true, false}) {
      auto s = packing(0.5e-3);
      s->bodies_mut().velocity_m_s[7] = Vec3{0.0, v, 0.0};
      if (!queued) ::setenv("BIODEM_GPU_QUEUED_CHECK", "0", 1);
      auto e = gpu_engine(*s);
      ::unsetenv("BIODEM_GPU_QUEUED_CHECK");
      std::string what;
      try {
        e->upload();
        for (int r = 0; r < 20; ++r) e->advance(7);
      } catch (const Error& err) {
        what = err.what();
      }
      std::printf("[measured] velocity %g, queued check %d: %s\n", v, queued ? 1 : 0, what.c_str());
      EXPECT_NE(what.find("has a non-finite position"), std::string::npos) << v << ", queued " << queued << ": " << what;
      EXPECT_NE(what.find("(of body 7)"), std::string::npos) << what;
      EXPECT_NE(what.find("dt_s"), std::string::npos) << what;
    }
}

namespace {
/// Spheres of two sizes (0.5 and 0.497 mm) on a jittered cubic lattice of 0.99 mm in a turning
/// cylinder of 6 mm (periodic along its axis, 5.94 mm), with gravity: every sphere overlaps its
/// neighbours (and the outer ones the wall) from the start, so each has several contacts at once
/// (cohesion and rolling friction on); the bed then springs apart over some hundred steps.
std::unique_ptr<sim::Simulation> compressed_bed() {
  constexpr double kR = 6e-3, kLz = 5.94e-3, kSpacing = 0.99e-3;
  SimSetup su;
  su.particle = {5e6, 0.3, 1000.0};
  su.wall = {5e6, 0.3, 0.0};
  su.particle_particle = {0.5, 0.5, 0.3, 5e4};
  su.particle_wall = {0.5, 0.4, 0.5, 2.5e4};
  su.templates = {sphere_template(0.5e-3), sphere_template(0.497e-3)};
  su.dt_s = 1e-5;
  su.gravity_m_s2 = Vec3{0, -9.81, 0};
  auto s = std::make_unique<sim::Simulation>(make_simulation(su));
  s->add_wall(cylinder_wall({0, 0, 0}, {0, 0, 1}, kR, 3.0));
  s->set_skin(0.3e-3);
  neighbor::Domain d;
  d.periodic = {false, false, true};
  d.lo_m = {0, 0, 0};
  d.hi_m = {0, 0, kLz};
  s->set_domain(d);
  std::mt19937_64 gen(31);
  const int n = static_cast<int>(kR / kSpacing);
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j)
      for (int l = 0; l < static_cast<int>(kLz / kSpacing + 0.5); ++l) {
        const Vec3 x{i * kSpacing + 1e-5 * (uniform(gen) - 0.5), j * kSpacing + 1e-5 * (uniform(gen) - 0.5),
                     (l + 0.5) * kSpacing};
        if (std::hypot(x.x, x.y) > kR - 0.495e-3) continue;
        add_particle(*s, static_cast<std::uint32_t>(gen() % 2), x, Vec3{}, Vec3{});
      }
  return s;
}
}  // namespace

// The order-free family (BIODEM_GPU_SUMS=fixed): each contact's force and torque added to its
// spheres' sums as fixed-point integers, in whatever order the threads get there. The packing
// (needles, and spheres only), stepped in runs across list checks, rebuilds, a criterion phase
// and an upload, once serially (one thread, the kernels as loops in index order) and once on
// four OpenMP threads with the parallel threshold 0 (the atomic additions race): bit-identical
// after every run. (Double sums added in the order the threads arrive would differ.)
TEST(GpuEngine, FixedSumsGiveTheSameBitsOnAnyNumberOfThreads) {
  for (const int scene : {0, 1, 2}) {
    SCOPED_TRACE(scene == 0 ? "needles" : scene == 1 ? "spheres" : "compressed bed");
    auto make = [scene] { return scene == 2 ? compressed_bed() : packing(1.2e-3, true, true, scene == 1); };
    auto a = make(), b = make();
    std::size_t most_contacts = 0;
    auto ea = gpu_engine(*a), eb = gpu_engine(*b);
    ea->set_fixed_sums(true);
    eb->set_fixed_sums(true);
    std::uint64_t steps = 0;
    {
      const ScopedThreads serial(1);
      ea->upload();
    }
    const ScopedThreads four(4);
    const std::size_t old = kParallelThreshold;
    set_parallel_threshold(0);
    eb->upload();
    set_parallel_threshold(old);
    // (step_alike_in_runs steps ea then eb each run: the threshold and threads switched around them)
    gpu::DeviceEngine::SettleCriterion never;
    never.min_steps = 1000000;
    const std::uint64_t runs[] = {37, 1, 113, 8, 64, 29, 200};
    for (std::size_t r = 0; r < std::size(runs); ++r) {
      if (r == 3) {
        ea->begin_settle(never, 0, 0);
        eb->begin_settle(never, 0, 0);
      }
      if (r == 5) {
        ea->end_settle();
        eb->end_settle();
      }
      {
        const ScopedThreads serial(1);
        EXPECT_EQ(ea->advance(runs[r]).steps, runs[r]);
        ea->download(true);
      }
      set_parallel_threshold(0);
      EXPECT_EQ(eb->advance(runs[r]).steps, runs[r]);
      eb->download(true);
      set_parallel_threshold(old);
      steps += runs[r];
      most_contacts = std::max(most_contacts, a->contact_count());
      const std::string diff = first_difference(*a, *b);
      EXPECT_EQ(diff, "") << "after run " << r << " (" << steps << " steps)";
      if (!diff.empty()) break;
      if (r == 4) {
        ea->upload();
        set_parallel_threshold(0);
        eb->upload();
        set_parallel_threshold(old);
      }
    }
    std::printf("[measured] fixed-point sums, 1 thread vs 4 threads at threshold 0: %zu bodies, %llu steps, %llu list "
                "builds, up to %zu contacts after a run; bit-identical after every run; %s\n",
                a->bodies().size(), static_cast<unsigned long long>(steps),
                static_cast<unsigned long long>(ea->list_builds()), most_contacts, ea->contact_kernels().c_str());
    EXPECT_EQ(ea->fixed_sum_passes(), steps);
    EXPECT_GT(ea->list_builds(), 5u);
    EXPECT_GT(most_contacts, scene == 2 ? 400u : 2u);
    EXPECT_NE(ea->contact_kernels().find("fixed-point"), std::string::npos) << ea->contact_kernels();
  }
}

// The fixed-point sums against the ordered double sums, from one state: after one step every
// sphere's force and torque are within their bound, (contacts + walls) / 2 quanta plus the
// double sums' own rounding; after 300 steps (list rebuilds, cohesion, rolling friction, a
// turning cylinder) the bodies are within 1e-9 m of the ordered run, as the dense packings of
// the two engines are (a sign, a factor 2 or a unit error in the fixed path moves them by
// 1e-6 m or more: a pair's force added with the same sign to both sides was checked to fail).
TEST(GpuEngine, FixedSumsStayWithinTheirQuantaOfTheOrderedSums) {
  auto a = compressed_bed(), b = compressed_bed();
  auto ea = gpu_engine(*a), eb = gpu_engine(*b);
  ea->set_fixed_sums(true);
  eb->set_entry_forces(true);
  ea->upload();
  eb->upload();
  const double qf = ea->fixed_force_quantum(), qt = ea->fixed_torque_quantum();
  ASSERT_GT(qf, 0.0);
  ASSERT_GT(qt, 0.0);
  // From the ordered engine's state, every 25 steps: one step of each, then every sphere's sums.
  double worst_f = 0.0, worst_t = 0.0, biggest_f = 0.0;
  std::size_t compared = 0;
  for (int round = 0; round < 8; ++round) {
    eb->download(true);
    *a = *b;
    ea->upload();
    ea->step();
    eb->step();
    ea->download(true);
    eb->download(true);
    EXPECT_EQ(a->contact_count(), b->contact_count());
    const auto &fa = a->spheres().force_n, &fb = b->spheres().force_n;
    const auto &ta = a->spheres().torque_n_m, &tb = b->spheres().torque_n_m;
    for (std::size_t i = 0; i < fa.size(); ++i) {
      // at most 20 contributions (rows and the wall) of half a quantum, and the double sums'
      // own rounding
      const double bound_f = 10.0 * qf + 1e-14 * norm(fb[i]), bound_t = 10.0 * qt + 1e-14 * norm(tb[i]);
      for (int c = 0; c < 3; ++c) {
        ASSERT_LE(std::fabs(fa[i][c] - fb[i][c]), bound_f) << "sphere " << i << " force " << c << ", round " << round;
        ASSERT_LE(std::fabs(ta[i][c] - tb[i][c]), bound_t) << "sphere " << i << " torque " << c << ", round " << round;
      }
      worst_f = std::max(worst_f, norm(fa[i] - fb[i]));
      worst_t = std::max(worst_t, norm(ta[i] - tb[i]));
      biggest_f = std::max(biggest_f, norm(fb[i]));
    }
    compared += b->contact_count();
    for (int k = 0; k < 24; ++k) eb->step();
  }
  EXPECT_GT(compared, 2000u);
  EXPECT_GT(biggest_f, 1e9 * qf);  // (forces far above the grid: the comparison means something)
  EXPECT_GT(worst_f, 0.0);         // (the rounding shows: the fixed sums did run)
  // Then 300 steps of each from one state: the trajectories stay within 1e-9 m.
  eb->download(true);
  *a = *b;
  ea->upload();
  for (int k = 0; k < 300; ++k) {
    ea->step();
    eb->step();
  }
  ea->download(true);
  eb->download(true);
  const double gap = worst_position_gap(*a, *b);
  std::printf("[measured] fixed-point vs ordered sums, compressed bed of %zu spheres: quanta %.3g N and %.3g N m; "
              "one step from one state (8 times, %zu contacts): worst force %.3g N and torque %.3g N m apart, largest "
              "force %.3g N; 300 steps from one state: bodies %.3g m apart, %zu vs %zu contacts\n",
              a->spheres().size(), qf, qt, compared, worst_f, worst_t, biggest_f, gap, a->contact_count(),
              b->contact_count());
  EXPECT_LT(gap, 1e-9);
  EXPECT_GE(ea->fixed_sum_passes(), 308u);
  EXPECT_EQ(eb->fixed_sum_passes(), 0u);
}

// A contribution beyond the fixed-point range (here a grid set for forces up to 1e-9 N, far
// below the packing's contacts) is refused and its spheres' sums taken as not-a-number: the run
// stops at the next list check with one line naming the sphere and the range.
TEST(GpuEngine, FixedSumsOutOfRangeStopTheRun) {
  auto s = packing(0.5e-3);
  auto e = gpu_engine(*s);
  e->set_fixed_sums(true);
  e->set_fixed_caps(1e-9, 1e-12);
  std::string what;
  try {
    e->upload();
    for (int r = 0; r < 20; ++r) e->advance(7);
  } catch (const Error& err) {
    what = err.what();
  }
  std::printf("[measured] fixed-point range exceeded: %s\n", what.c_str());
  EXPECT_NE(what.find("has a non-finite position"), std::string::npos) << what;
  EXPECT_NE(what.find("BIODEM_GPU_SUMS=fixed"), std::string::npos) << what;
  EXPECT_NE(what.find("beyond its range of"), std::string::npos) << what;
}

// The per-contact passes over the lists made at each list build of the pairs' lower-id entries
// and of the wall slots within reach (BIODEM_GPU_PAIR_LIST=compact, the default), against the
// passes over every row entry and wall slot (full): the packing (a turning cylinder) and the
// compressed bed (its spheres against the cylinder from the start) stepped in runs across list
// checks, rebuilds (with sorts of the bodies), a criterion phase and an upload are bit-identical
// after every run, with the entry kernels and with the fixed-point sums; the list holds every
// pair of the rows once and a part of the wall slots. (It fails when the pair list drops its
// last entry, or when the wall slots' reach leaves out the skin: checked.)
TEST(GpuEngine, PairListGivesTheBitsOfThePassOverEveryEntry) {
  for (const int scene : {0, 1, 2, 3}) {
    const bool fixed = scene % 2 == 1;
    SCOPED_TRACE(std::string(fixed ? "fixed-point sums" : "entry kernels") + (scene >= 2 ? ", compressed bed" : ""));
    auto make = [scene] { return scene >= 2 ? compressed_bed() : packing(0.5e-3); };
    auto a = make(), b = make();
    auto ea = gpu_engine(*a);
    ::setenv("BIODEM_GPU_PAIR_LIST", "full", 1);
    auto eb = gpu_engine(*b);
    ::unsetenv("BIODEM_GPU_PAIR_LIST");
    for (auto* e : {ea.get(), eb.get()}) {
      e->set_entry_forces(true);
      if (fixed) e->set_fixed_sums(true);
      e->set_check_every(3);
      e->upload();
    }
    const std::uint64_t steps = step_alike_in_runs(*ea, *eb, *a, *b, true);
    std::size_t unmirrored = 1;
    const auto pairs = ea->list_pairs(&unmirrored);
    std::printf("[measured] pair list vs every entry (%s%s): %llu steps, %llu list builds, %lld pairs listed, %zu in "
                "the rows, %lld of %zu wall slots listed, %zu contacts at the end; bit-identical after every run\n",
                fixed ? "fixed-point sums" : "entry kernels", scene >= 2 ? ", compressed bed" : "",
                static_cast<unsigned long long>(steps), static_cast<unsigned long long>(ea->list_builds()),
                static_cast<long long>(ea->listed_pairs()), pairs.size(), static_cast<long long>(ea->listed_wall_slots()),
                a->spheres().size() * a->walls().size(), a->contact_count());
    EXPECT_EQ(unmirrored, 0u);
    EXPECT_EQ(ea->listed_pairs(), static_cast<std::int64_t>(pairs.size()));
    EXPECT_GT(pairs.size(), 100u);
    EXPECT_GT(ea->listed_wall_slots(), 10);
    EXPECT_LT(ea->listed_wall_slots(), static_cast<std::int64_t>(a->spheres().size() * a->walls().size() / 2));
    EXPECT_EQ(eb->listed_pairs(), -1);
    EXPECT_EQ(eb->listed_wall_slots(), -1);
    EXPECT_GT(ea->list_builds(), 5u);
    EXPECT_GT(ea->entry_force_passes(), steps / 2);
  }
}

// The order-free family through its switch (BIODEM_GPU_SUMS=fixed, as the physics tests' second
// run in ctest, GpuEngineFixedSums.PhysicsTests, sets it): the engine runs the fixed-point sums
// and says so; with fixed-point sums fused and unfused body kernels give the same bits; turning
// the family off and on again mid-run, or a settle phase that halts the kernels, leaves no sums
// behind (the run goes on bit-identical to an engine uploaded from its state); and asking for the
// row walk runs the family's row walk (ForcesFixed), which the report names.
TEST(GpuEngine, FixedSumsByTheSwitchFusedUnfusedAndMidRun) {
  {
    auto s = packing(0.5e-3);
    ::setenv("BIODEM_GPU_SUMS", "fixed", 1);
    auto e = gpu_engine(*s);
    ::unsetenv("BIODEM_GPU_SUMS");
    e->upload();
    e->advance(30);
    EXPECT_TRUE(e->fixed_sums());
    EXPECT_EQ(e->fixed_sum_passes(), 30u);
    EXPECT_NE(e->contact_kernels().find("fixed-point"), std::string::npos) << e->contact_kernels();
  }
  {
    const auto r = stepped_alike(
        0.5e-3, false, true, [](gpu::DeviceEngine& e) { e.set_fixed_sums(true); },
        [](gpu::DeviceEngine& e) {
          e.set_fixed_sums(true);
          e.set_fused_kick(false);
        });
    EXPECT_EQ(r.ea->fixed_sum_passes(), r.steps);
    EXPECT_EQ(r.eb->fixed_sum_passes(), r.steps);
    EXPECT_GT(r.ea->fused_steps(), r.steps / 2);
    EXPECT_EQ(r.eb->fused_steps(), 0u);
  }
  // continue engine e on its host s, against a fresh engine uploaded from s's state
  auto continue_vs_fresh = [](gpu::DeviceEngine& e, sim::Simulation& s, std::uint64_t steps) {
    e.download(true);
    auto c = std::make_unique<sim::Simulation>(s);
    auto ec = gpu_engine(*c);
    ec->set_fixed_sums(true);
    ec->upload();
    e.advance(steps);
    ec->advance(steps);
    e.download(true);
    ec->download(true);
    return first_difference(s, *c);
  };
  {
    auto s = packing(0.5e-3);
    auto e = gpu_engine(*s);
    e->set_fixed_sums(true);
    e->upload();
    e->advance(57);
    e->set_fixed_sums(false);
    e->advance(31);
    e->set_fixed_sums(true);
    EXPECT_EQ(continue_vs_fresh(*e, *s, 120), "") << "off and on again";
  }
  {
    auto s = packing(0.5e-3);
    auto e = gpu_engine(*s);
    e->set_fixed_sums(true);
    e->upload();
    e->advance(40);
    gpu::DeviceEngine::SettleCriterion c;
    c.threshold_j = 1e30;
    c.min_steps = 13;
    e->begin_settle(c, 0, 0);
    const auto r = e->advance(100);
    EXPECT_TRUE(r.settled);
    EXPECT_EQ(r.steps, 13u);
    e->end_settle();
    EXPECT_EQ(continue_vs_fresh(*e, *s, 120), "") << "after a halted settle phase";
  }
  {
    auto s = packing(0.5e-3);
    auto e = gpu_engine(*s);
    e->set_fixed_sums(true);
    e->set_entry_forces(false);  // the family's row walk
    e->upload();
    e->advance(20);
    EXPECT_EQ(e->fixed_sum_passes(), 20u);
    EXPECT_EQ(e->entry_force_passes(), 0u);
    EXPECT_NE(e->contact_kernels().find("ForcesFixed"), std::string::npos) << e->contact_kernels();
  }
}

// The order-free family's two sets give the same bits: the row walk by one thread per sphere
// with its sums as integers (ForcesFixed; each pair evaluated in both rows) and the per-contact
// kernels with atomic additions (PairEntriesFixed). The packing (needles, then spheres) and the
// compressed bed, in runs across list checks, rebuilds, a criterion phase and an upload: bit-
// identical after every run; and the timed choice switching between the two sets in the middle
// of the runs (BIODEM_GPU_FORCES=timed, re-timed every 60 steps) against the per-contact set.
// (With the force of a pair's higher-id side not negated in the walk it fails: checked.)
TEST(GpuEngine, FixedSumsRowWalkGivesTheBitsOfThePerContactKernels) {
  for (const int scene : {0, 1, 2}) {
    SCOPED_TRACE(scene == 0 ? "needles" : scene == 1 ? "spheres" : "compressed bed");
    auto make = [scene] { return scene == 2 ? compressed_bed() : packing(0.5e-3, true, true, scene == 1); };
    {
      auto a = make(), b = make();
      auto ea = gpu_engine(*a), eb = gpu_engine(*b);
      ea->set_fixed_sums(true);
      ea->set_entry_forces(false);
      eb->set_fixed_sums(true);
      eb->set_entry_forces(true);
      ea->upload();
      eb->upload();
      const std::uint64_t steps = step_alike_in_runs(*ea, *eb, *a, *b, true);
      std::printf("[measured] fixed-point row walk vs per-contact kernels: %llu steps, %llu list builds, %zu contacts "
                  "at the end; bit-identical after every run\n",
                  static_cast<unsigned long long>(steps), static_cast<unsigned long long>(ea->list_builds()),
                  a->contact_count());
      EXPECT_EQ(ea->fixed_sum_passes(), steps);
      EXPECT_EQ(ea->entry_force_passes(), 0u);
      EXPECT_EQ(eb->entry_force_passes(), steps);
      EXPECT_GT(a->contact_count(), 2u);
    }
    {
      auto a = make(), b = make();
      ::setenv("BIODEM_GPU_FORCES", "timed", 1);
      auto ea = gpu_engine(*a);
      ::unsetenv("BIODEM_GPU_FORCES");
      auto eb = gpu_engine(*b);
      ea->set_fixed_sums(true);
      eb->set_fixed_sums(true);
      eb->set_entry_forces(true);
      ea->set_check_every(3);
      eb->set_check_every(3);
      ea->set_retime_every(60);
      ea->upload();
      eb->upload();
      const std::uint64_t steps = step_alike_in_runs(*ea, *eb, *a, *b, true);
      std::printf("[measured] fixed-point sums, timed choice vs per-contact kernels: %llu steps, %llu by the "
                  "per-contact kernels; %s\n",
                  static_cast<unsigned long long>(steps), static_cast<unsigned long long>(ea->entry_force_passes()),
                  ea->contact_kernels().c_str());
      EXPECT_GT(ea->entry_force_passes(), 0u);
      EXPECT_LT(ea->entry_force_passes(), steps);
      EXPECT_EQ(ea->fixed_sum_passes(), steps);
    }
  }
}

// A scene uploaded empty after one with pairs: the pair list of the first is not read (before:
// the passes read its count and divided by zero spheres).
TEST(GpuEngine, EmptySceneAfterAFullOneRunsWithThePairList) {
  for (const bool fixed : {false, true}) {
    auto s = packing(0.5e-3);
    auto e = gpu_engine(*s);
    e->set_entry_forces(true);
    if (fixed) e->set_fixed_sums(true);
    e->upload();
    e->advance(20);
    EXPECT_GT(e->listed_pairs(), 0);
    SimSetup su;
    su.particle = {5e6, 0.3, 1000.0};
    su.wall = {5e6, 0.3, 0.0};
    su.particle_particle = {0.5, 0.5, 0.3, 0.0};
    su.particle_wall = {0.5, 0.4, 0.5, 0.0};
    su.templates = {sphere_template(0.5e-3)};
    su.dt_s = 1e-5;
    *s = make_simulation(su);
    e->upload();
    EXPECT_EQ(e->listed_pairs(), 0);
    EXPECT_EQ(e->advance(5).steps, 5u);
  }
}

// The contact kernels reading each sphere from its 96-byte record (BIODEM_GPU_RECORDS=1) and the
// one-thread walk holding its own sphere for the whole row (BIODEM_GPU_OWN_SPHERE=1), against the
// default loads from the arrays: the packing of needles and beads (the compressed bed of beads for
// the sets of single-sphere scenes) stepped in runs across list checks, rebuilds with sorts of the bodies, a criterion
// phase and an upload is bit-identical after every run, in every kernel set that reads a sphere
// (the row walk, with the body update in two buffers, the entry kernels with the sums apart, in
// the body kernel and by the row walk, both order-free sets), serially and on two threads. (It
// fails when a sort does not refill the records, when a clump's spheres' motion skips its
// record, and when the walk with the body update does not copy the second buffer's records
// back: checked.)
TEST(GpuEngine, SphereRecordsAndTheWalksOwnSphereGiveTheBitsOfTheArrays) {
  struct Set {
    const char* name;
    bool spheres_only, entries, walk_kick, sum_lanes, fixed, records, own, parallel;
    const char* body_lanes = nullptr;  // BIODEM_GPU_BODY_LANES (on CPU threads: the lanes' kernel, one lane)
  };
  const Set sets[] = {
      {"row walk, records and own sphere", false, false, false, false, false, true, true, true},
      {"row walk, records", false, false, false, false, false, true, false, false},
      {"row walk, own sphere from the arrays", false, false, false, false, false, false, true, false},
      {"row walk with the body update, records and own sphere", true, false, true, false, false, true, true, true},
      {"entry kernels, records", false, true, false, false, false, true, true, false},
      {"entry kernels with the sums in the body kernel, records", true, true, false, false, false, true, false, true},
      {"entry sums by the row walk, records", true, true, false, true, false, true, false, false},
      {"order-free per-contact, records", false, true, false, false, true, true, false, true},
      {"order-free row walk, records and own sphere", false, false, false, false, true, true, true, false},
      {"row walk, records, the clumps' body kernel by lanes", false, false, false, false, false, true, false, true, "4"},
      {"entry kernels, the clumps' body kernel by lanes", false, true, false, false, false, false, false, false, "auto"},
      {"clumps' row walk with the body update by groups, records", false, false, true, false, false, true, false, true},
  };
  for (const Set& set : sets) {
    SCOPED_TRACE(set.name);
    const ScopedThreads scoped(set.parallel ? 2 : 1);
    const std::size_t old = kParallelThreshold;
    if (set.parallel) set_parallel_threshold(0);
    // (single spheres: the compressed bed, hundreds of contacts with cohesion and rolling
    // friction; clumps: the packing of needles and beads, colliding)
    auto make = [&set] { return set.spheres_only ? compressed_bed() : packing(0.5e-3); };
    auto a = make(), b = make();
    ::setenv("BIODEM_GPU_RECORDS", set.records ? "1" : "0", 1);
    ::setenv("BIODEM_GPU_OWN_SPHERE", set.own ? "1" : "0", 1);
    if (set.body_lanes) ::setenv("BIODEM_GPU_BODY_LANES", set.body_lanes, 1);
    auto ea = gpu_engine(*a);
    ::unsetenv("BIODEM_GPU_RECORDS");
    ::unsetenv("BIODEM_GPU_OWN_SPHERE");
    ::unsetenv("BIODEM_GPU_BODY_LANES");
    auto eb = gpu_engine(*b);
    for (auto* e : {ea.get(), eb.get()}) {
      e->set_entry_forces(set.entries);
      if (set.fixed) e->set_fixed_sums(true);
      if (!set.fixed) e->set_walk_kick(set.walk_kick);
      if (!set.fixed) e->set_sum_lanes(set.sum_lanes);
      e->set_check_every(3);
      e->upload();
    }
    std::size_t most = 0;
    const std::uint64_t steps = step_alike_in_runs(*ea, *eb, *a, *b, true, &most);
    set_parallel_threshold(old);
    std::printf("[measured] %s vs the arrays: %llu steps, %llu list builds, %llu body sorts, up to %zu contacts "
                "after a run; bit-identical after every run\n",
                set.name, static_cast<unsigned long long>(steps), static_cast<unsigned long long>(ea->list_builds()),
                static_cast<unsigned long long>(ea->body_sorts()), most);
    EXPECT_GT(ea->list_builds(), 5u);
    EXPECT_GT(ea->body_sorts(), 1u);
    EXPECT_GT(most, 10u);
    if (set.walk_kick) {
      EXPECT_GT(ea->walk_kick_steps(), steps / 2);
    }
    if (set.entries) {
      EXPECT_GT(ea->entry_force_passes(), steps / 2);
    }
    if (set.fixed) {
      EXPECT_EQ(ea->fixed_sum_passes(), steps);
    }
    const std::string how = ea->contact_kernels();
    EXPECT_EQ(how.find("BIODEM_GPU_RECORDS=1") != std::string::npos, set.records) << how;
    EXPECT_EQ(how.find("BIODEM_GPU_OWN_SPHERE=1") != std::string::npos, set.own) << how;
    // (auto: the packing's needles have 3 spheres, so 4 lanes)
    EXPECT_EQ(how.find("by 4 lanes per body") != std::string::npos, set.body_lanes != nullptr) << how;
    EXPECT_EQ(eb->contact_kernels().find("BIODEM_GPU_RECORDS"), std::string::npos);
    EXPECT_EQ(eb->contact_kernels().find("BIODEM_GPU_OWN_SPHERE"), std::string::npos);
  }
}

// The row walks with the touching contacts shared by a warp's lanes (BIODEM_GPU_WALK_PACK=1,
// walk_packed: on CPU threads a group of one lane, whose cut-off tests run apart from the
// evaluations), against the walk by one thread: the packing of needles and beads in its
// cylinder, the compressed bed of beads with the walk and the body update in one kernel
// (ForcesKickDrift), and a box periodic along x, y and z (image shifts in the tests), stepped in
// runs across list checks, rebuilds with sorts of the bodies, a criterion phase and an upload:
// bit-identical after every run, serially and on two threads, with the spheres read from the
// arrays and from their records, and with the clumps' walk with the body update by groups of
// lanes per body (ForcesKickDriftGroups, WalkKickGroups::run_packed). The entry kernels are not
// packed, and run.log says so. (It fails when the pair test says "apart" for every pair, or the
// wall test for every wall: checked.)
TEST(GpuEngine, WarpsSharingTheirTouchingContactsGiveTheBitsOfTheWalk) {
  struct Set {
    const char* name;
    int scene;  // 0: packing, 1: compressed bed, 2: periodic box
    bool walk_kick, records, parallel;
  };
  const Set sets[] = {
      {"needles and beads, row walk", 0, false, false, false},
      {"needles and beads, row walk, two threads", 0, false, false, true},
      {"needles and beads, row walk, records", 0, false, true, false},
      {"needles and beads, clumps' walk with the body update by groups, two threads", 0, true, false, true},
      {"needles and beads, clumps' walk with the body update by groups, records", 0, true, true, false},
      {"bed of beads, row walk with the body update, two threads", 1, true, false, true},
      {"bed of beads, row walk, records", 1, false, true, false},
      {"periodic box, row walk", 2, false, false, true},
  };
  for (const Set& set : sets) {
    SCOPED_TRACE(set.name);
    const ScopedThreads scoped(set.parallel ? 2 : 1);
    const std::size_t old = kParallelThreshold;
    if (set.parallel) set_parallel_threshold(0);
    auto make = [&set] {
      return set.scene == 0 ? packing(0.5e-3) : set.scene == 1 ? compressed_bed() : periodic_box(0.3e-3);
    };
    auto a = make(), b = make();
    ::setenv("BIODEM_GPU_WALK_PACK", "1", 1);
    ::setenv("BIODEM_GPU_RECORDS", set.records ? "1" : "0", 1);
    auto ea = gpu_engine(*a);
    ::unsetenv("BIODEM_GPU_WALK_PACK");
    auto eb = gpu_engine(*b);
    ::unsetenv("BIODEM_GPU_RECORDS");
    for (auto* e : {ea.get(), eb.get()}) {
      e->set_entry_forces(false);
      e->set_walk_kick(set.walk_kick);
      e->set_check_every(3);
      e->upload();
    }
    std::size_t most = 0;
    const std::uint64_t steps = step_alike_in_runs(*ea, *eb, *a, *b, true, &most);
    set_parallel_threshold(old);
    std::printf("[measured] %s, touching contacts shared vs one thread per row: %llu steps, %llu list builds, up to "
                "%zu contacts after a run; bit-identical after every run\n",
                set.name, static_cast<unsigned long long>(steps), static_cast<unsigned long long>(ea->list_builds()),
                most);
    EXPECT_GT(ea->list_builds(), 2u);
    EXPECT_GT(most, 10u);
    if (set.walk_kick) {
      EXPECT_GT(ea->walk_kick_steps(), steps / 2);
    }
    const std::string how = ea->contact_kernels();
    EXPECT_NE(how.find("share their touching contacts across its lanes (BIODEM_GPU_WALK_PACK=1"), std::string::npos) << how;
    EXPECT_EQ(eb->contact_kernels().find("BIODEM_GPU_WALK_PACK"), std::string::npos);
  }
  // Where no row walk runs, the switch is named as unused.
  for (const bool fixed : {false, true}) {
    auto s = packing(0.5e-3);
    ::setenv("BIODEM_GPU_WALK_PACK", "1", 1);
    auto e = gpu_engine(*s);
    ::unsetenv("BIODEM_GPU_WALK_PACK");
    e->set_entry_forces(!fixed);
    if (fixed) e->set_fixed_sums(true);
    e->upload();
    EXPECT_EQ(e->advance(20).steps, 20u);
    EXPECT_NE(e->contact_kernels().find("BIODEM_GPU_WALK_PACK=1 unused (no ordered row walk)"), std::string::npos)
        << e->contact_kernels();
  }
}

// The switches of how the spheres are loaded and of the body kernel's lanes take their values
// and nothing else, named in the error.
TEST(GpuEngine, SphereLoadSwitchesRefuseOtherValues) {
  auto s = packing(0.5e-3);
  for (const char* name : {"BIODEM_GPU_RECORDS", "BIODEM_GPU_OWN_SPHERE", "BIODEM_GPU_BODY_LANES", "BIODEM_GPU_WALK_PACK"}) {
    ::setenv(name, "3", 1);
    try {
      auto e = gpu_engine(*s);
      ADD_FAILURE() << name << " = 3 was accepted";
    } catch (const Error& err) {
      EXPECT_EQ(std::string(err.what()), std::string(name) + " = '3': expected " +
                                             (std::string(name) == "BIODEM_GPU_BODY_LANES" ? "1, 2, 4, 8, 16, 32 or auto"
                                                                                           : "0 or 1"));
    }
    ::unsetenv(name);
  }
}
