// The list guard's device words (gpu/kernels.hpp: StepFlags, Halt, halted, set_motion,
// CopySphereMotion; docs/gpu.md, "The list guard"), kernel by kernel on CPU threads: which flags a
// kernel reads, which it raises, and what the copy of the second motion buffer does with them.
// The engine tests (test_gpu_engine.cpp, SphereOutrunning...) check the whole: the trajectories
// of runs the guard stopped against the CPU engine's.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#define BIODEM_GPU_NS guard_test
#include "gpu/kernels.hpp"

using namespace biodem;
using namespace biodem::gpu::guard_test;

namespace {

struct Spheres {
  std::vector<Vec3> pos, vel, omega, built;
  explicit Spheres(std::size_t n) : pos(n), vel(n), omega(n), built(n) {}
  SphereArrays arrays(StepFlags* g, double half_skin, std::uint32_t buffer) {
    SphereArrays s{};
    s.position = pos.data();
    s.velocity = vel.data();
    s.omega = omega.data();
    s.built_at = built.data();
    s.guard = g;
    s.half_skin2 = 0.25 * (2.0 * half_skin) * (2.0 * half_skin);
    s.buffer = buffer;
    return s;
  }
};

}  // namespace

// A kernel stops on a raised flag it does not ignore, raises `stop` as it does, and every later
// kernel stops on `stop` alone; the settle flag stops every kernel; Halt{} never stops.
TEST(ListGuard, AKernelStopsOnTheFlagsItReadsAndRaisesStop) {
  StepFlags g;
  EXPECT_FALSE(halted(Halt{}));
  EXPECT_FALSE(halted(Halt{nullptr, &g, 0u}));
  g.over[1] = 1;
  EXPECT_FALSE(halted(Halt{nullptr, &g, 2u})) << "a kernel that raises over[1] does not read it";
  EXPECT_EQ(g.stop, 0u);
  EXPECT_TRUE(halted(Halt{nullptr, &g, 1u})) << "a kernel that raises over[0] reads over[1]";
  EXPECT_EQ(g.stop, 1u) << "a kernel stopped by a flag raises stop";
  StepFlags h;
  h.stop = 1;
  EXPECT_TRUE(halted(Halt{nullptr, &h, 3u})) << "stop stops every kernel, whatever it ignores";
  StepFlags k;
  k.over[0] = 1;
  EXPECT_FALSE(halted(Halt{nullptr, &k, 1u}));
  EXPECT_TRUE(halted(Halt{nullptr, &k, 2u}));
  const std::uint32_t settled = 1;
  StepFlags none;
  EXPECT_TRUE(halted(Halt{&settled, &none, 0u}));
  EXPECT_EQ(none.stop, 0u) << "a met settle criterion is not the guard's stop";
}

// set_motion: a sphere stored past half the skin from its build position, or at a non-finite
// one, raises the flag of the buffer written; at or within half the skin it does not; sphere 0
// counts the drift; arrays without the guard (set-up, reads) touch no flag.
TEST(ListGuard, SetMotionRaisesTheFlagOfItsBufferPastHalfTheSkin) {
  const double half = 5e-8;
  Spheres sp(3);
  StepFlags g;
  const SphereArrays s = sp.arrays(&g, half, 1);
  set_motion(s, 0, {half, 0, 0}, {}, {});            // exactly half the skin: within
  set_motion(s, 1, {0, -0.99 * half, 0}, {}, {});
  EXPECT_EQ(g.over[0] + g.over[1], 0u);
  EXPECT_EQ(g.drifts, 1u) << "sphere 0 counts the drift";
  set_motion(s, 2, {0, 0, 1.0001 * half}, {}, {});
  EXPECT_EQ(g.over[1], 1u);
  EXPECT_EQ(g.over[0], 0u) << "the flag of the buffer written only";
  EXPECT_EQ(g.drifts, 1u);
  EXPECT_EQ(sp.pos[2].z, 1.0001 * half) << "the motion is stored all the same";

  StepFlags n;
  const SphereArrays s0 = sp.arrays(&n, half, 0);
  set_motion(s0, 1, {std::numeric_limits<double>::quiet_NaN(), 0, 0}, {}, {});
  EXPECT_EQ(n.over[0], 1u) << "a non-finite position raises the flag";
  EXPECT_EQ(n.drifts, 0u);

  StepFlags untouched;
  SphereArrays plain = sp.arrays(nullptr, half, 0);
  set_motion(plain, 0, {1.0, 0, 0}, {}, {});
  EXPECT_EQ(untouched.over[0] + untouched.over[1] + untouched.stop, 0u);
}

// The copy of the second motion buffer back to the first at the end of an odd run of two-buffer
// units: after a last unit whose drift raised over[1], it copies and raises over[0] (the first
// buffer now holds that motion, and the next run's first unit, which ignores over[1], must stop);
// after a stop it copies nothing (guard_take_back copies the buffer the stopping drift wrote).
TEST(ListGuard, TheSecondBufferCopyMovesItsFlagAndStopsAfterAStop) {
  std::vector<Vec3> a{{1, 2, 3}, {4, 5, 6}}, b(2), va(2), vb(2), wa(2), wb(2);
  auto copy = [&](StepFlags* g) {
    return CopySphereMotion{a.data(), va.data(), wa.data(), b.data(), vb.data(), wb.data(), nullptr, nullptr,
                            Halt{nullptr, g, 3u}};
  };
  StepFlags g;
  g.over[1] = 1;
  const CopySphereMotion c = copy(&g);
  c(0);
  c(1);
  EXPECT_EQ(b[1].y, 5.0);
  EXPECT_EQ(g.over[0], 1u) << "the flag moves with the motion";
  EXPECT_EQ(g.stop, 0u);

  b.assign(2, Vec3{});
  StepFlags s;
  s.stop = 1;
  s.over[1] = 1;
  const CopySphereMotion d = copy(&s);
  d(0);
  d(1);
  EXPECT_EQ(b[0].x, 0.0) << "nothing copied after a stop";
  EXPECT_EQ(s.over[0], 0u);

  StepFlags clear;
  const CopySphereMotion e = copy(&clear);
  e(0);
  EXPECT_EQ(b[0].x, 1.0);
  EXPECT_EQ(clear.over[0], 0u) << "no flag raised without one";
}

// ClearGuardOver (at a list build) lowers the over flags and keeps stop and the drift count.
TEST(ListGuard, AListBuildLowersTheOverFlags) {
  StepFlags g;
  g.over[0] = g.over[1] = 1;
  g.drifts = 7;
  ClearGuardOver{&g}(0);
  EXPECT_EQ(g.over[0] + g.over[1], 0u);
  EXPECT_EQ(g.drifts, 7u);
}
