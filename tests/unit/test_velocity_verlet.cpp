// The velocity-Verlet parts shared by the CPU and GPU engines (src/integrate/velocity_verlet.hpp)
// against closed forms: under a constant force and torque one step (half kick, drift, half kick
// with the same force) is exact, x1 = x0 + v0 dt + F dt^2 / (2 m), v1 = v0 + F dt / m; a single
// sphere's spin gains T dt / I; a clump's lab angular momentum gains T dt. A harmonic oscillator
// keeps its energy to O(dt^2) and its period to the known Verlet shift. A sign or a factor 2 in
// any half kick or the drift fails these.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>

#include "integrate/velocity_verlet.hpp"

using namespace biodem;
using namespace biodem::integrate;

TEST(VelocityVerlet, ConstantForceStepIsExact) {
  const double m = 2.5e-6, dt = 1e-5, h = 0.5 * dt;
  const Vec3 f{3e-5, -2.4525e-5, 1e-6}, t{2e-12, 0.0, -1e-12};
  const Vec3 x0{0.01, 0.02, 0.003}, v0{0.1, -0.3, 0.05}, w0{10.0, -4.0, 2.0};
  const Vec3 inertia{4e-13, 4e-13, 4e-13};
  Vec3 x = x0, v = v0, w = w0, l{};
  Quat q{1, 0, 0, 0};
  kick_and_drift(x, v, w, l, q, m, inertia, 1, f, t, h, dt);
  half_kick(v, w, l, q, m, inertia, 1, f, t, h);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(x[k], x0[k] + v0[k] * dt + f[k] * dt * dt / (2.0 * m), 1e-15) << k;
    EXPECT_NEAR(v[k], v0[k] + f[k] * dt / m, 1e-13 * (1.0 + std::abs(v[k]))) << k;
    EXPECT_NEAR(w[k], w0[k] + t[k] * dt / inertia.x, 1e-12) << k;
  }
}

TEST(VelocityVerlet, ClumpLabAngularMomentumGainsTheTorqueImpulse) {
  const double m = 1e-5, dt = 1e-5, h = 0.5 * dt;
  const Vec3 inertia{1e-12, 4e-12, 4e-12};  // a needle: not spun as a sphere
  const Vec3 t{3e-12, -1e-12, 2e-12};
  Vec3 x{}, v{}, w{}, l{1e-11, 0.0, 0.0};
  const Vec3 l0 = l;
  Quat q{1, 0, 0, 0};
  kick_and_drift(x, v, w, l, q, m, inertia, 3, {}, t, h, dt);
  half_kick(v, w, l, q, m, inertia, 3, {}, t, h);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(l[k], l0[k] + t[k] * dt, 1e-24) << k;
  // omega = R I^-1 R^T L at the new orientation.
  const Quat qn = q;
  const Vec3 w_expect = angular_velocity_from_momentum(qn, l, inertia);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(w[k], w_expect[k]) << k;
  EXPECT_NEAR(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z, 1.0, 1e-12);  // still a unit quaternion
}

// x'' = -k/m x over 10 periods at 100 steps per period: velocity Verlet's energy, read at the
// steps, swings by up to (omega dt)^2 / 4 of its start (relative; measured 9.8696e-4 against
// 9.8696e-4), without drift, and its frequency is (2/dt) asin(omega dt / 2).
TEST(VelocityVerlet, HarmonicOscillatorEnergyAndPhase) {
  const double m = 1.0, k = 4.0 * std::numbers::pi * std::numbers::pi;  // period 1 s
  const double dt = 0.01, h = 0.5 * dt;
  Vec3 x{1.0, 0, 0}, v{}, w{}, l{};
  Quat q{1, 0, 0, 0};
  const Vec3 inertia{1, 1, 1};
  Vec3 f = -k * x;
  double worst = 0.0;
  const double e0 = 0.5 * k;
  for (int n = 0; n < 1000; ++n) {
    kick_and_drift(x, v, w, l, q, m, inertia, 1, f, {}, h, dt);
    f = -k * x;
    half_kick(v, w, l, q, m, inertia, 1, f, {}, h);
    worst = std::max(worst, std::abs(0.5 * m * dot(v, v) + 0.5 * k * dot(x, x) - e0) / e0);
  }
  const double wdt = 2.0 * std::numbers::pi * dt;
  EXPECT_LT(worst, wdt * wdt / 4.0 * 1.02);
  EXPECT_GT(worst, wdt * wdt / 4.0 * 0.9);  // the known swing, not zero
  // Phase after 10 periods: Verlet's frequency is (2/dt) asin(omega dt / 2).
  const double omega_v = 2.0 / dt * std::asin(wdt / 2.0);
  EXPECT_NEAR(x.x, std::cos(omega_v * 10.0), 1e-6);
}

// half_kick_then_kick_and_drift (the GPU engine's fused body kernels) is half_kick then
// kick_and_drift bit for bit (compared as bit patterns: signed zeros and NaN payloads too): for a
// single sphere, for a sphere-shaped body with unequal moments, and for clumps of 2 and 3
// spheres, over random states, forces and torques, and with a NaN, an infinite or a zero force
// and torque (the clumps' angular velocity from half_kick, which it skips, is replaced by the
// turn).
TEST(VelocityVerlet, FusedHalvesGiveTheBitsOfTheTwoFunctions) {
  std::uint64_t s = 0x9e3779b97f4a7c15ull;
  auto uni = [&] {  // xorshift64*: [-1, 1)
    s ^= s >> 12;
    s ^= s << 25;
    s ^= s >> 27;
    return static_cast<double>((s * 2685821657736338717ull) >> 11) * 0x1p-52 - 1.0;
  };
  auto vec = [&](double scale) { return Vec3{scale * uni(), scale * uni(), scale * uni()}; };
  auto bits = [](double x) { return std::bit_cast<std::uint64_t>(x); };
  const double dt = 1e-5, h = 0.5 * dt;
  int clumps_turned = 0;
  for (int n = 0; n < 400; ++n) {
    const std::uint32_t count = static_cast<std::uint32_t>(n % 4 == 0 ? 1 : n % 4);
    const double m = 1e-5 * (1.5 + uni());
    const Vec3 inertia = n % 4 == 0 ? (n % 8 == 0 ? Vec3{2e-11, 2e-11, 2e-11} : Vec3{2e-11, 3e-11, 2e-11})
                                    : Vec3{1e-11 * (1.5 + uni()), 3e-11 * (1.5 + uni()), 3e-11 * (1.5 + uni())};
    Quat q = normalized(Quat{uni(), uni(), uni(), uni()});
    const Vec3 x0 = vec(0.05), v0 = vec(0.5), w0 = vec(30.0);
    Vec3 f = vec(1e-3), t = vec(1e-7);
    if (n % 50 == 1) f.y = std::numeric_limits<double>::quiet_NaN();
    if (n % 50 == 2) t.z = std::numeric_limits<double>::infinity();
    if (n % 50 == 3) f = t = Vec3{};
    const Vec3 l0 = angular_momentum_from_velocity(q, w0, inertia);
    Vec3 xa = x0, va = v0, wa = w0, la = l0, xb = x0, vb = v0, wb = w0, lb = l0;
    Quat qa = q, qb = q;
    half_kick(va, wa, la, qa, m, inertia, count, f, t, h);
    kick_and_drift(xa, va, wa, la, qa, m, inertia, count, f, t, h, dt);
    half_kick_then_kick_and_drift(xb, vb, wb, lb, qb, m, inertia, count, f, t, h, dt);
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(bits(xa[k]), bits(xb[k])) << n;
      EXPECT_EQ(bits(va[k]), bits(vb[k])) << n;
      EXPECT_EQ(bits(wa[k]), bits(wb[k])) << n;
      EXPECT_EQ(bits(la[k]), bits(lb[k])) << n;
    }
    EXPECT_EQ(bits(qa.w), bits(qb.w)) << n;
    EXPECT_EQ(bits(qa.x), bits(qb.x)) << n;
    EXPECT_EQ(bits(qa.y), bits(qb.y)) << n;
    EXPECT_EQ(bits(qa.z), bits(qb.z)) << n;
    if (!spins_as_sphere(count, inertia) && !(qa.w == q.w)) ++clumps_turned;
  }
  EXPECT_GT(clumps_turned, 250);  // the clump path ran and turned the bodies
}
