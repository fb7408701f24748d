// The clumps' step in SIMD lanes (sim/body_lanes.hpp, advance_clump_bodies_lanes{4,8}) against
// the scalar functions it stands for, on random clumps: the sums of the spheres' forces and
// torques, integrate::half_kick, integrate::kick_and_drift_but_turn, integrate::free_rotation_step
// and the spheres placed by the new orientation (Simulation::place_spheres_of), then the list's
// displacement test. Tolerance: none (the same IEEE operations in the same order, no FMA).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "core/mat3.hpp"
#include "core/quat.hpp"
#include "core/small_angle.hpp"
#include "integrate/rigid_rotation.hpp"
#include "integrate/velocity_verlet.hpp"
#include "sim/body_lanes.hpp"
#include "sim/pair_pass.hpp"

namespace biodem {
namespace {

#if defined(BIODEM_X86_LANES)

struct Bodies {
  std::uint32_t n = 3;  // spheres per body
  std::vector<std::uint32_t> first;
  std::vector<double> mass;
  std::vector<Vec3> inertia, x, v, w, l, f, t;
  std::vector<Quat> q;
  std::vector<Vec3> sf, st, sx, sv, sw, built, offset;
};

Bodies random_bodies(std::size_t count, std::uint32_t n, std::uint64_t seed, double spin_rad_s, std::size_t mover_every) {
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto vec = [&](double scale) { return Vec3{scale * u(g), scale * u(g), scale * u(g)}; };
  Bodies b;
  b.n = n;
  for (std::size_t i = 0; i < count; ++i) {
    b.first.push_back(static_cast<std::uint32_t>(i * n));
    b.mass.push_back(1.4e-5 * (1.0 + 0.5 * u(g)));
    const Vec3 inertia{1.3e-11 * (1.0 + 0.3 * u(g)), 6.8e-11 * (1.0 + 0.3 * u(g)), 6.9e-11 * (1.0 + 0.3 * u(g))};
    b.inertia.push_back(inertia);
    b.x.push_back(vec(0.2));
    b.v.push_back(vec(0.5));
    b.w.push_back(vec(50.0));
    b.q.push_back(normalized(Quat{u(g), u(g), u(g), u(g)}));
    // Angular momentum for spins of about spin_rad_s about each axis.
    b.l.push_back(rotate(b.q.back(), Vec3{inertia.x * spin_rad_s * u(g), inertia.y * spin_rad_s * u(g),
                                          inertia.z * spin_rad_s * u(g)}));
    b.f.push_back(vec(1e-3));
    b.t.push_back(vec(1e-6));
    for (std::uint32_t k = 0; k < n; ++k) {
      b.offset.push_back(Vec3{(static_cast<double>(k) - 0.5 * (n - 1)) * 2.4e-3, 1e-5 * u(g), 1e-5 * u(g)});
      const Vec3 arm = rotate(b.q.back(), b.offset.back());
      b.sx.push_back(b.x.back() + arm);
      b.sf.push_back(vec(2e-3));
      b.st.push_back(vec(1e-6));
      b.sv.push_back(vec(1.0));
      b.sw.push_back(vec(1.0));
      // Every mover_every-th body 1 mm from its build position (beyond the list's limit of
      // 0.1 mm), the others within 17 um of it (and at 200 rad/s within the limit after the step).
      b.built.push_back(b.sx.back() + vec(i % mover_every == 0 ? 1e-3 : 1e-5));
    }
  }
  return b;
}

constexpr double kDt = 1e-5;
const Vec3 kGravity{0.0, -9.81, 0.0};
constexpr double kLimit2 = 1e-4 * 1e-4;

/// The scalar path (Simulation::advance_bodies' clump branch, turn_waiting, place_spheres_of).
int scalar_step(Bodies& b, std::size_t i, bool kick_first) {
  const double h = 0.5 * kDt;
  const std::uint32_t s0 = b.first[i], n = b.n;
  Vec3 x = b.x[i], v = b.v[i], w = b.w[i], l = b.l[i], f, t;
  if (kick_first) {
    f = b.mass[i] * kGravity;
    for (std::uint32_t s = s0; s < s0 + n; ++s) {
      f += b.sf[s];
      t += b.st[s] + cross(b.sx[s] - x, b.sf[s]);
    }
    b.f[i] = f;
    b.t[i] = t;
    integrate::half_kick(v, w, l, b.q[i], b.mass[i], b.inertia[i], n, f, t, h);
  } else {
    f = b.f[i];
    t = b.t[i];
  }
  EXPECT_FALSE(integrate::kick_and_drift_but_turn(x, v, w, l, b.mass[i], b.inertia[i], n, f, t, h, kDt));
  w = integrate::free_rotation_step(b.q[i], l, b.inertia[i], kDt);
  b.x[i] = x;
  b.v[i] = v;
  b.w[i] = w;
  b.l[i] = l;
  const Mat3 r = to_matrix(b.q[i]);
  int moved = 0;
  for (std::uint32_t s = s0; s < s0 + n; ++s) {
    const Vec3 arm = r * b.offset[s];
    b.sx[s] = x + arm;
    b.sv[s] = v + cross(w, arm);
    b.sw[s] = w;
    if (!(norm2(b.sx[s] - b.built[s]) <= kLimit2)) moved = 1;
  }
  return moved;
}

sim::BodyLaneArrays arrays_of(Bodies& b) {
  sim::BodyLaneArrays a{b.first.data(), b.mass.data(), b.inertia.data(), b.x.data(), b.v.data(), b.w.data(),
                        b.f.data(),     b.t.data(),    b.sf.data(),      b.st.data(), b.sx.data(), b.sv.data(),
                        b.sw.data(),    b.built.data(), kGravity,        0.5 * kDt,  kDt,         kLimit2,
                        true};
  a.orientation = b.q.data();
  a.body_l = b.l.data();
  a.offset_body = b.offset.data();
  return a;
}

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

void expect_same(const Bodies& a, const Bodies& b, const std::string& what) {
  EXPECT_TRUE(same_bits(a.x, b.x)) << what << ": body positions";
  EXPECT_TRUE(same_bits(a.v, b.v)) << what << ": body velocities";
  EXPECT_TRUE(same_bits(a.w, b.w)) << what << ": angular velocities";
  EXPECT_TRUE(same_bits(a.l, b.l)) << what << ": angular momenta";
  EXPECT_TRUE(same_bits(a.q, b.q)) << what << ": orientations";
  EXPECT_TRUE(same_bits(a.f, b.f)) << what << ": body forces";
  EXPECT_TRUE(same_bits(a.t, b.t)) << what << ": body torques";
  EXPECT_TRUE(same_bits(a.sx, b.sx)) << what << ": sphere positions";
  EXPECT_TRUE(same_bits(a.sv, b.sv)) << what << ": sphere velocities";
  EXPECT_TRUE(same_bits(a.sw, b.sw)) << what << ": sphere angular velocities";
}

using ClumpLanes = int (*)(const sim::BodyLaneArrays&, std::size_t, std::uint32_t);

/// Runs `lanes` over bodies [0, count) in groups of `width` and the scalar path over a copy.
void compare(ClumpLanes lanes, std::size_t width, bool kick_first, std::uint32_t n, double spin, std::uint64_t seed,
             int& groups_moved, int& groups_still) {
  const std::size_t count = 6 * width;
  // A body 1 mm off its build position in every other group: groups that must and must not
  // report a move.
  Bodies scalar = random_bodies(count, n, seed, spin, 2 * width), lane = scalar;
  // Bodies with a sub-step half angle beyond the series: R1 and R2 turn by dt/2 (half angle
  // dt/4 * omega_k), R3 by dt (half angle dt/2 * omega_z), omega_k = pi_k / I_k at the start.
  int beyond = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const Vec3 pi = rotate_inverse(scalar.q[i], scalar.l[i]);
    const Vec3& in = scalar.inertia[i];
    const double half = std::max({0.25 * kDt * std::abs(pi.x / in.x), 0.25 * kDt * std::abs(pi.y / in.y),
                                  0.5 * kDt * std::abs(pi.z / in.z)});
    beyond += half > kSmallAngleMax;
  }
  if (spin > 1e4)
    EXPECT_GT(beyond, 0) << "the large spins do not leave the series";
  else
    EXPECT_EQ(beyond, 0);
  const sim::BodyLaneArrays a = arrays_of(lane);
  for (std::size_t g = 0; g < count; g += width) {
    int moved = 0;
    for (std::size_t i = g; i < g + width; ++i) moved |= scalar_step(scalar, i, kick_first);
    const int lane_moved = lanes(a, g, n);
    EXPECT_EQ(lane_moved, moved) << "group " << g / width;
    (lane_moved ? groups_moved : groups_still) += 1;
  }
  expect_same(scalar, lane,
              std::to_string(width) + " lanes, n = " + std::to_string(n) + (kick_first ? ", kick first" : "") +
                  ", spin " + std::to_string(spin) + " rad/s");
}

TEST(BodyLanes, ClumpStepGivesTheScalarFunctionsBits) {
  struct Width {
    sim::PairKernel kernel;
    ClumpLanes plain, kick_first;
    std::size_t width;
  };
  const Width widths[] = {
      {sim::PairKernel::Lanes4, &sim::advance_clump_bodies_lanes4<false>, &sim::advance_clump_bodies_lanes4<true>, 4},
      {sim::PairKernel::Lanes8, &sim::advance_clump_bodies_lanes8<false>, &sim::advance_clump_bodies_lanes8<true>, 8}};
  int compared = 0, moved = 0, still = 0;
  for (const Width& wd : widths) {
    if (!sim::pair_kernel_available(wd.kernel)) continue;
    for (std::uint32_t n : {2u, 3u, 4u, 5u})
      for (bool kick_first : {false, true})
        // 200 rad/s: every sub-step angle on the series; 2e4 rad/s: half of them beyond 1/16 rad,
        // on the library's sine and cosine, lane by lane.
        for (double spin : {200.0, 2.0e4}) {
          compare(kick_first ? wd.kick_first : wd.plain, wd.width, kick_first, n, spin, 7 + n, moved, still);
          ++compared;
        }
  }
  if (compared == 0) GTEST_SKIP() << "this CPU has neither AVX2 nor AVX-512F";
  EXPECT_GT(moved, 0) << "no group crossed the list's displacement limit: the test does not see it";
  EXPECT_GT(still, 0) << "every group crossed the list's displacement limit: the test does not see a false move";
}

// The displacement test's two other cases: without build positions (have_built false: no
// move is reported, the state is the same) and with a non-finite position (a NaN velocity: the
// move is reported, as the scalar test's !(d2 <= limit) does, so the run's next build fails).
TEST(BodyLanes, ClumpStepWithoutBuildPositionsAndWithANaN) {
  struct Width {
    sim::PairKernel kernel;
    ClumpLanes lanes;
    std::size_t width;
  };
  const Width widths[] = {{sim::PairKernel::Lanes4, &sim::advance_clump_bodies_lanes4<true>, 4},
                          {sim::PairKernel::Lanes8, &sim::advance_clump_bodies_lanes8<true>, 8}};
  int compared = 0;
  for (const Width& wd : widths) {
    if (!sim::pair_kernel_available(wd.kernel)) continue;
    ++compared;
    Bodies scalar = random_bodies(wd.width, 3, 5, 200.0, 1), lane = scalar;  // every body 1 mm off
    sim::BodyLaneArrays a = arrays_of(lane);
    a.have_built = false;
    for (std::size_t i = 0; i < wd.width; ++i) scalar_step(scalar, i, true);
    EXPECT_EQ(wd.lanes(a, 0, 3), 0) << wd.width << " lanes, no build positions";
    expect_same(scalar, lane, std::to_string(wd.width) + " lanes, no build positions");

    Bodies nan_scalar = random_bodies(wd.width, 3, 6, 200.0, 1);
    nan_scalar.built = nan_scalar.sx;  // every sphere at its build position: only the NaN moves
    nan_scalar.v[1].x = std::nan("");
    Bodies nan_lane = nan_scalar;
    int moved = 0;
    for (std::size_t i = 0; i < wd.width; ++i) moved |= scalar_step(nan_scalar, i, true);
    EXPECT_EQ(moved, 1);
    EXPECT_EQ(wd.lanes(arrays_of(nan_lane), 0, 3), 1) << wd.width << " lanes, a NaN velocity";
  }
  if (compared == 0) GTEST_SKIP() << "this CPU has neither AVX2 nor AVX-512F";
}

#endif

}  // namespace
}  // namespace biodem
