// Determinism across thread counts (SPEC 10: checkpoints resume bit for bit on the same build
// and thread count; the engine promises more: bit-identical for any thread count, see
// sim/simulation.hpp). The same random packing of spheres and needle clumps, with friction,
// rolling friction, cohesion, a turning cylinder and a periodic axis (every slot of the contact
// model and every branch of the neighbour list), is run with 1 and with 2 OpenMP threads.
// Tolerance: none, the states must be bit-identical.
#include <gtest/gtest.h>

#include "core/error.hpp"

#include <omp.h>

#include <chrono>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "core/parallel.hpp"
#include "physics_support.hpp"

using namespace biodem;
using namespace biodem::phys;

namespace {

constexpr double kRc = 20e-3, kLz = 12e-3, kSpacing = 3e-3;

double uniform(std::mt19937_64& g) { return static_cast<double>(g() >> 11) * 0x1.0p-53; }

struct Snapshot {
  std::vector<Vec3> x, v, w;
  std::vector<Quat> q;
  std::vector<std::uint32_t> id;
  std::size_t contacts = 0, builds = 0;
};

Snapshot run(int threads, std::uint64_t steps, std::size_t sort_every_builds = 16, bool far_sink = false,
             sim::PairKernel kernel = sim::best_pair_kernel(), bool steps_ahead = false, int only_shape = -1,
             bool tangential_reduce = false) {
  const ScopedThreads scoped(threads);
  EXPECT_EQ(omp_get_max_threads(), threads);
  // The system is small: lower the serial threshold so that every loop really runs threaded.
  struct Threshold {
    std::size_t old = kParallelThreshold;
    Threshold() { set_parallel_threshold(0); }
    ~Threshold() { set_parallel_threshold(old); }
  } threshold;
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
  su.gravity_m_s2 = {0, -9.81, 0};
  su.tangential_reduce = tangential_reduce;
  sim::Simulation s = make_simulation(su);
  s.set_sort_every_builds(sort_every_builds);
  s.set_pair_kernel(kernel);
  s.add_wall(cylinder_wall({0, 0, 0}, {0, 0, 1}, kRc, 3.0));
  neighbor::Domain d;
  d.periodic = {false, false, true};
  d.lo_m = {0, 0, 0};
  d.hi_m = {0, 0, kLz};
  s.set_domain(d);
  if (far_sink) {
    // Removes nothing (1 m below the drum) but sends every step down the engine's other path
    // (drift as its own pass, sinks, then the forces), which must give the same bits.
    sim::SinkSpec sink;
    sink.point_m = {0, -1.0, 0};
    s.add_sink(sink);
  }

  std::mt19937_64 gen(2024);
  const int n = static_cast<int>(kRc / kSpacing);
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j)
      for (int l = 0; l < static_cast<int>(kLz / kSpacing); ++l) {
        const Vec3 x{i * kSpacing, j * kSpacing, (l + 0.5) * kSpacing};
        if (std::hypot(x.x, x.y) > kRc - 2.5e-3) continue;
        const auto drawn = static_cast<std::uint32_t>(gen() % 3);
        const std::uint32_t shape = only_shape < 0 ? drawn : static_cast<std::uint32_t>(only_shape);
        Quat q{uniform(gen) - 0.5, uniform(gen) - 0.5, uniform(gen) - 0.5, uniform(gen) - 0.5};
        q = normalized(q);
        const Vec3 v{uniform(gen) - 0.5, uniform(gen) - 0.5, uniform(gen) - 0.5};
        const Vec3 w{200 * (uniform(gen) - 0.5), 200 * (uniform(gen) - 0.5), 200 * (uniform(gen) - 0.5)};
        add_particle(s, shape, x, 2.0 * v, w, q);
      }
  Snapshot out;
  for (std::uint64_t k = 0; k < steps; ++k) {
    s.step(steps_ahead && k + 1 < steps);
    out.contacts += s.contact_count();
    if (s.steps_ahead() && k == steps / 2) {
      EXPECT_THROW((void)s.bodies(), Error) << "the state is half a step ahead";
      EXPECT_THROW((void)s.kinetic_energy_j(), Error);
    }
  }
  EXPECT_FALSE(s.steps_ahead());
  out.x = s.bodies().position_m;
  out.v = s.bodies().velocity_m_s;
  out.w = s.bodies().angular_velocity_rad_s;
  out.q = s.bodies().orientation;
  out.id = s.bodies().id;
  out.builds = s.neighbor_list().builds();
  return out;
}

template <class T>
bool bitwise_equal(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

}  // namespace

void expect_identical(const Snapshot& a, const Snapshot& b, const char* what) {
  EXPECT_EQ(a.contacts, b.contacts) << what;
  EXPECT_EQ(a.builds, b.builds) << what;
  EXPECT_TRUE(bitwise_equal(a.id, b.id)) << what << ": storage orders differ";
  EXPECT_TRUE(bitwise_equal(a.x, b.x)) << what << ": positions differ";
  EXPECT_TRUE(bitwise_equal(a.v, b.v)) << what << ": velocities differ";
  EXPECT_TRUE(bitwise_equal(a.w, b.w)) << what << ": angular velocities differ";
  EXPECT_TRUE(bitwise_equal(a.q, b.q)) << what << ": orientations differ";
}

// 1, 2, 3 and 4 threads (3 and 4 oversubscribe a 2-core machine, which changes nothing but the
// time): each thread count cuts the bodies into different blocks.
TEST(Determinism, OneTwoThreeAndFourThreadsGiveBitIdenticalStates) {
  const std::uint64_t steps = 300;
  const auto t0 = std::chrono::steady_clock::now();
  const Snapshot a = run(1, steps);
  const auto t1 = std::chrono::steady_clock::now();
  const Snapshot b = run(2, steps);
  const auto t2 = std::chrono::steady_clock::now();
  std::printf("[timing] 1 thread %.3f s, 2 threads %.3f s\n", std::chrono::duration<double>(t1 - t0).count(),
              std::chrono::duration<double>(t2 - t1).count());
  std::printf("[measured] determinism: %zu bodies, %llu steps, %zu contact-steps, %zu list builds\n", a.x.size(),
              static_cast<unsigned long long>(steps), a.contacts, a.builds);
  ASSERT_GT(a.x.size(), 300u);
  EXPECT_GT(a.contacts, 1000u) << "the packing must collide for the test to mean anything";
  EXPECT_GT(a.builds, 1u) << "the neighbour list must be rebuilt at least once";
  expect_identical(a, b, "1 vs 2 threads");
  expect_identical(a, run(3, steps), "1 vs 3 threads");
  expect_identical(a, run(4, steps), "1 vs 4 threads");
}

// A scene with a sink runs each step as separate passes (drift, sinks, forces); one without runs
// it in one parallel region. A sink that removes nothing must not change a bit.
TEST(Determinism, OneRegionStepAndSeparatePassesGiveBitIdenticalStates) {
  const std::uint64_t steps = 300;
  const Snapshot plain = run(2, steps);
  const Snapshot with_sink = run(2, steps, 16, true);
  ASSERT_EQ(plain.x.size(), with_sink.x.size());
  expect_identical(plain, with_sink, "one region vs separate passes");
}

// step(true) ends with the next step's half kick, drift and placement done in the force pass's
// blocks (Simulation::step); the run driver uses it between outputs. Same bits as plain steps,
// on one and two threads, with list rebuilds and spatial sorts in between (tolerance zero).
TEST(Determinism, StepsMadeAheadGiveThePlainStepsBits) {
  const std::uint64_t steps = 300;
  for (int threads : {1, 2}) {
    const Snapshot plain = run(threads, steps);
    const Snapshot ahead = run(threads, steps, 16, false, sim::best_pair_kernel(), true);
    EXPECT_GT(plain.builds, 1u);
    expect_identical(plain, ahead, threads == 1 ? "1 thread: plain vs ahead" : "2 threads: plain vs ahead");
  }
}

// Spatial re-sorting of the bodies (a renumbering with the contact history remapped) must not
// change the physics: the same packing run with re-sorting at every neighbour-list build and
// with none agrees body by body (matched by stable id). Not bit-identical: the per-sphere force
// sums run in a different order. Tolerance 1e-9 m (~1e-6 of a radius): round-off differences
// (1e-16 relative) grow through the collisions of 300 steps but stay many orders below it,
// while a history lost or remapped with the wrong sign changes tangential forces by O(1).
TEST(Determinism, SpatialSortingDoesNotChangeTrajectories) {
  const ScopedThreads one_thread(1);
  const std::uint64_t steps = 300;
  const Snapshot sorted = run(1, steps, 1);
  const Snapshot plain = run(1, steps, 0);
  ASSERT_EQ(sorted.x.size(), plain.x.size());
  std::size_t moved = 0;
  double worst_x = 0.0, worst_w = 0.0;
  for (std::size_t q = 0; q < sorted.x.size(); ++q) {
    const std::uint32_t id = sorted.id[q];
    ASSERT_EQ(plain.id[id], id);
    if (id != q) ++moved;
    worst_x = std::max(worst_x, norm(sorted.x[q] - plain.x[id]));
    worst_w = std::max(worst_w, norm(sorted.w[q] - plain.w[id]));
  }
  std::printf("[measured] sorting: %zu of %zu bodies renumbered, worst |dx| = %.3g m, worst |dw| = %.3g rad/s\n",
              moved, sorted.x.size(), worst_x, worst_w);
  EXPECT_GT(moved, sorted.x.size() / 2) << "the re-sorting did not happen";
  EXPECT_LT(worst_x, 1e-9);
  EXPECT_LT(worst_w, 1e-3);  // spins reach ~100 rad/s: 1e-5 relative
}

// The spatial sort puts the bed's longest extent first (planes across it, rows along the shortest
// extent): the threads' blocks are contiguous index ranges, so they are then cut where the bed's
// cross-section is smallest. A lattice box 40 x 12 x 4 mm, turned so that each axis in turn is
// the long one, translated until the list is rebuilt (and re-sorted): along the storage order
// the long-axis coordinate must never decrease (the lattice spacing exceeds the sort's cell, so
// two lattice planes never share a cell). The former z-major order fails for the x- and y-long
// boxes: it cuts a thin drum across its axis, where every sphere has a neighbour in the other
// thread's block.
TEST(Determinism, SpatialSortCutsAcrossTheLongestExtent) {
  const ScopedThreads one_thread(1);
  for (int major = 0; major < 3; ++major) {
    SimSetup su;
    su.particle = {5e6, 0.3, 1000.0};
    su.wall = {5e6, 0.3, 0.0};
    su.particle_particle = {0.5, 0.5, 0.0, 0.0};
    su.particle_wall = {0.5, 0.5, 0.0, 0.0};
    su.templates = {sphere_template(0.5e-3)};
    su.dt_s = 1e-5;
    sim::Simulation s = make_simulation(su);
    s.set_sort_every_builds(1);
    const double h = 1.3e-3;  // lattice spacing > sort cell (2 r + skin = 1.125 mm)
    const int counts[3] = {30, 9, 3};  // long, middle, short (in lattice steps)
    const int a_mid = (major + 1) % 3, a_min = (major + 2) % 3;
    std::mt19937_64 gen(7);
    std::vector<Vec3> sites;
    for (int i = 0; i < counts[0]; ++i)
      for (int j = 0; j < counts[1]; ++j)
        for (int k = 0; k < counts[2]; ++k) {
          Vec3 x{};
          x[major] = i * h;
          x[a_mid] = j * h;
          x[a_min] = k * h;
          sites.push_back(x);
        }
    std::shuffle(sites.begin(), sites.end(), gen);  // storage order unrelated to space
    for (const Vec3& x : sites) add_particle(s, 0, x, {0.3, 0.2, 0.1});
    for (int k = 0; k < 40; ++k) s.step();
    ASSERT_GE(s.neighbor_list().builds(), 2u) << "no rebuild, so no re-sort";
    const auto& x = s.bodies().position_m;
    int descents = 0;
    for (std::size_t q = 1; q < x.size(); ++q)
      if (x[q][major] < x[q - 1][major] - 1e-9) ++descents;
    EXPECT_EQ(descents, 0) << "long axis " << major << ": the storage order is not planes across it";
  }
}

// The step's thread team after a 2-thread job must still run a 1-thread job (a scene below the
// parallel threshold, or --threads 1 after a larger run in the same process): its barriers
// return at once instead of waiting for a second thread.
TEST(Determinism, OneThreadJobAfterATwoThreadJobDoesNotWait) {
  const Snapshot two = run(2, 50);
  const Snapshot one = run(1, 50);
  expect_identical(one, two, "1 thread after 2 threads");
}

// The pair pass's SIMD kernels (sim/pair_pass.hpp), and with them the wall batches of the same
// width, against the scalar reference on the whole engine: spheres and needle clumps, cohesion,
// rolling friction, a turning cylinder, a periodic axis, 2 threads. Tolerance: none (tests/unit/test_pair_pass.cpp says why the bits agree).
TEST(Determinism, EveryPairKernelGivesTheScalarKernelsBits) {
  const std::uint64_t steps = 300;
  int compared = 0;
  // Both friction rules (the reduced one, cohesion inside the limits, takes its own branch in
  // the particle and the wall lanes): cohesive beds, CED 5e4 and 2.5e4 J/m^3.
  std::vector<Snapshot> scalars;
  for (const bool reduce : {false, true}) {
    const Snapshot scalar = run(2, steps, 16, false, sim::PairKernel::Scalar, false, -1, reduce);
    scalars.push_back(scalar);
    for (sim::PairKernel k : {sim::PairKernel::Lanes2, sim::PairKernel::Lanes4, sim::PairKernel::Lanes8}) {
      if (!sim::pair_kernel_available(k)) continue;
      const std::string what = sim::pair_kernel_name(k) + (reduce ? ", tangential_reduce" : ", default rule");
      expect_identical(scalar, run(2, steps, 16, false, k, false, -1, reduce), what.c_str());
      ++compared;
    }
  }
  // (the reduced rule is seen: its trajectories are not the default rule's)
  EXPECT_NE(scalars[0].x, scalars[1].x) << "tangential_reduce changed nothing in 300 steps of a cohesive bed";
  std::printf("[measured] pair kernels equal to the scalar pass, bit for bit: %d\n", compared);
  EXPECT_GE(compared, 1);
}

// A bed of needles only (clumps of 3 spheres): runs of eight (four) clumps go through the body
// lanes of the 8-lane (4-lane) kernels (sim/body_lanes.hpp: sums, kicks, drift, free-rotor turn,
// spheres placed), which must give the scalar path's bits, with the bodies' step made on its
// own and fused with the next step's drift (steps ahead). Tolerance: none.
TEST(Determinism, ClumpLanesGiveTheScalarPathsBits) {
  const std::uint64_t steps = 200;
  int compared = 0;
  for (const bool ahead : {false, true}) {
    const Snapshot scalar = run(2, steps, 16, false, sim::PairKernel::Scalar, ahead, 2);
    ASSERT_GT(scalar.x.size(), 100u);
    EXPECT_GT(scalar.builds, 1u) << "no list build after the first: the displacement test is not seen";
    EXPECT_GT(scalar.contacts, 0u);
    for (sim::PairKernel k : {sim::PairKernel::Lanes4, sim::PairKernel::Lanes8}) {
      if (!sim::pair_kernel_available(k)) continue;
      const std::string what = sim::pair_kernel_name(k) + (ahead ? ", steps ahead" : ", plain steps");
      expect_identical(scalar, run(2, steps, 16, false, k, ahead, 2), what.c_str());
      ++compared;
    }
  }
  std::printf("[measured] needle beds equal to the scalar path, bit for bit: %d\n", compared);
  if (compared == 0) GTEST_SKIP() << "this CPU has neither AVX2 nor AVX-512F";
}
