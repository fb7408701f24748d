// The fixed-point sums of the GPU engine's order-free family (src/gpu/fixed_sums.hpp and
// FixedSumArrays in gpu/kernels.hpp): the grid, the rounding, the refusal of values beyond the
// range, and sums that are the same bits in any order and from any number of threads, within
// their stated bound of the exact sum.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numeric>
#include <random>
#include <thread>
#include <vector>

#define BIODEM_GPU_NS fixed_test
#include "gpu/kernels.hpp"

using namespace biodem;
using namespace biodem::gpu;

// The grid of a cap is a power of two with cap * scale in [2^55, 2^56): the largest grid that
// holds the cap below 2^56 quanta.
TEST(FixedSums, GridIsThePowerOfTwoThatHoldsTheCap) {
  for (const double cap : {1e-12, 3.7e-5, 0.5, 1.0, 1.5, 1024.0, 6.02e23}) {
    const double scale = fixed::scale_for(cap);
    int e = 0;
    EXPECT_EQ(std::frexp(scale, &e), 0.5) << cap;  // a power of two
    EXPECT_LT(cap * scale, std::ldexp(1.0, 56)) << cap;
    EXPECT_GE(cap * scale, std::ldexp(1.0, 55)) << cap;
  }
  EXPECT_EQ(fixed::scale_for(0.0), fixed::scale_for(1.0));  // no contact can arise: any grid
  EXPECT_EQ(fixed::scale_for(std::nan("")), fixed::scale_for(1.0));
  EXPECT_EQ(fixed::limit_for(64), std::ldexp(1.0, 56));
  EXPECT_EQ(fixed::limit_for(0), std::ldexp(1.0, 62));
}

// Rounding to nearest with ties to even, symmetric (so a pair's force added to one side and,
// negated, to the other cancels exactly), and refusal beyond the limit or of not-a-number.
TEST(FixedSums, RoundsToNearestEvenAndRefusesWhatIsOutOfRange) {
  const double scale = 4.0, limit = 100.0;  // quanta of 0.25
  bool ok = true;
  EXPECT_EQ(fixed::to_fixed(0.625, scale, limit, ok), 2);  // 2.5 quanta: to even
  EXPECT_EQ(fixed::to_fixed(0.875, scale, limit, ok), 4);  // 3.5 quanta: to even
  EXPECT_EQ(fixed::to_fixed(-0.625, scale, limit, ok), -2);
  EXPECT_EQ(fixed::to_fixed(0.3, scale, limit, ok), 1);
  EXPECT_EQ(fixed::to_fixed(-0.38, scale, limit, ok), -2);
  EXPECT_EQ(fixed::to_fixed(25.0, scale, limit, ok), 100);  // at the limit: kept
  EXPECT_TRUE(ok);
  EXPECT_EQ(fixed::to_fixed(25.01, scale, limit, ok), 0);
  EXPECT_FALSE(ok);
  for (const double bad : {-25.01, std::nan(""), HUGE_VAL, -HUGE_VAL}) {
    ok = true;
    EXPECT_EQ(fixed::to_fixed(bad, scale, limit, ok), 0) << bad;
    EXPECT_FALSE(ok) << bad;
  }
  std::mt19937_64 g(7);
  for (int k = 0; k < 1000; ++k) {
    const double x = std::ldexp(static_cast<double>(g() >> 11) * 0x1.0p-53 - 0.5, static_cast<int>(g() % 40) - 20);
    ok = true;
    const long long q = fixed::to_fixed(x, 0x1.0p30, 0x1.0p62, ok), m = fixed::to_fixed(-x, 0x1.0p30, 0x1.0p62, ok);
    ASSERT_TRUE(ok);
    EXPECT_EQ(q, -m) << x;
    EXPECT_LE(std::fabs(fixed::from_fixed(q, 0x1.0p-30) - x), 0x1.0p-31) << x;  // half a quantum
  }
  EXPECT_EQ(fixed::from_fixed(-3, 0.25), -0.75);
  EXPECT_EQ(fixed::from_fixed(0, 0.25), 0.0);
}

namespace {
/// Contributions to one sphere of a FixedSumArrays of `n` spheres, added by `threads` threads in
/// the order of `order`, then taken.
struct Taken {
  Vec3 f, t;
  std::uint32_t count = 0;
};
Taken add_and_take(const std::vector<Vec3>& fs, const std::vector<Vec3>& ts, const std::vector<std::size_t>& order,
                   unsigned threads, double force_scale, double torque_scale) {
  const std::uint32_t n = 3, i = 1;
  std::vector<long long> sums(fixed_test::FixedSumArrays::kWords * n, 0);
  const fixed_test::FixedSumArrays fx{sums.data(), force_scale, 1.0 / force_scale, torque_scale, 1.0 / torque_scale,
                                      fixed::limit_for(64)};
  std::vector<std::thread> team;
  for (unsigned w = 0; w < threads; ++w)
    team.emplace_back([&, w] {
      for (std::size_t k = w; k < order.size(); k += threads) fx.add(i, fs[order[k]], ts[order[k]], order[k] % 2 == 0);
    });
  for (auto& th : team) th.join();
  Taken r;
  fx.take(i, r.f, r.t, r.count);
  EXPECT_TRUE(std::all_of(sums.begin(), sums.end(), [](long long v) { return v == 0; })) << "taken sums are zeroed";
  return r;
}
}  // namespace

// 40 contributions spanning eight decades (where double sums in another order differ in their
// last bits), added in shuffled orders by 1, 2 and 8 threads at once (atomic additions that
// race): the same bits every time, within (contributions / 2) quanta of the exact sum (long
// double), the count of the counted ones; a pair's force added to both sides cancels exactly.
TEST(FixedSums, SumsAreTheSameBitsInAnyOrderAndFromAnyNumberOfThreads) {
  std::mt19937_64 g(11);
  auto value = [&] {
    return std::ldexp(static_cast<double>(g() >> 11) * 0x1.0p-53 - 0.5, -static_cast<int>(g() % 27));  // 1 to 1e-8
  };
  std::vector<Vec3> fs(40), ts(40);
  for (std::size_t k = 0; k < fs.size(); ++k) {
    fs[k] = Vec3{value(), value(), value()};
    ts[k] = 1e-3 * Vec3{value(), value(), value()};
  }
  const double force_scale = fixed::scale_for(4.0), torque_scale = fixed::scale_for(4e-3);
  std::vector<std::size_t> order(fs.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  const Taken first = add_and_take(fs, ts, order, 1, force_scale, torque_scale);
  bool double_sums_differ = false;
  double in_order = 0.0;
  for (std::size_t k : order) in_order += fs[k].x;
  for (int trial = 0; trial < 20; ++trial) {
    std::shuffle(order.begin(), order.end(), g);
    const Taken r = add_and_take(fs, ts, order, trial % 3 == 0 ? 1u : trial % 3 == 1 ? 2u : 8u, force_scale, torque_scale);
    EXPECT_EQ(std::memcmp(&r.f, &first.f, sizeof(Vec3)), 0) << "trial " << trial;
    EXPECT_EQ(std::memcmp(&r.t, &first.t, sizeof(Vec3)), 0) << "trial " << trial;
    EXPECT_EQ(r.count, 20u);
    double shuffled = 0.0;
    for (std::size_t k : order) shuffled += fs[k].x;
    double_sums_differ = double_sums_differ || shuffled != in_order;
  }
  EXPECT_TRUE(double_sums_differ) << "the values must be such that double sums depend on the order";
  long double exact_f = 0.0L, exact_t = 0.0L;
  for (std::size_t k = 0; k < fs.size(); ++k) {
    exact_f += fs[k].x;
    exact_t += ts[k].z;
  }
  EXPECT_LE(std::fabs(static_cast<long double>(first.f.x) - exact_f), 20.0L / force_scale);
  EXPECT_LE(std::fabs(static_cast<long double>(first.t.z) - exact_t), 20.0L / torque_scale);
  EXPECT_GT(std::fabs(static_cast<double>(exact_f)), 1e3 / force_scale);  // (not a sum of nothing)

  // a pair: +f on i, -f on j, each side's torque; the count on i only
  std::vector<long long> sums(fixed_test::FixedSumArrays::kWords * 2, 0);
  const fixed_test::FixedSumArrays fx{sums.data(), force_scale, 1.0 / force_scale, torque_scale, 1.0 / torque_scale,
                                      fixed::limit_for(64)};
  fx.add_pair(0, 1, fs[3], ts[3], ts[4]);
  Taken a, b;
  fx.take(0, a.f, a.t, a.count);
  fx.take(1, b.f, b.t, b.count);
  EXPECT_EQ(a.f.x, -b.f.x);
  EXPECT_EQ(a.f.y, -b.f.y);
  EXPECT_EQ(a.f.z, -b.f.z);
  EXPECT_LE(std::fabs(a.f.y - fs[3].y), 0.5 / force_scale);
  EXPECT_LE(std::fabs(b.t.z - ts[4].z), 0.5 / torque_scale);
  EXPECT_EQ(a.count, 1u);
  EXPECT_EQ(b.count, 0u);
}

// A contribution beyond the range adds nothing and flags its sphere (both spheres of a pair):
// its sums are then taken as not-a-number (which stops the run), the flag cleared with them.
TEST(FixedSums, AContributionOutOfRangeMakesTheSumsNotANumber) {
  std::vector<long long> sums(fixed_test::FixedSumArrays::kWords * 2, 0);
  const double scale = fixed::scale_for(1.0);
  const fixed_test::FixedSumArrays fx{sums.data(), scale, 1.0 / scale, scale, 1.0 / scale, fixed::limit_for(64)};
  fx.add(0, Vec3{0.5, 0, 0}, Vec3{}, true);
  fx.add(0, Vec3{0.25, 0, 0}, Vec3{}, true);
  Vec3 f, t;
  std::uint32_t c = 0;
  fx.take(0, f, t, c);
  EXPECT_EQ(f.x, 0.75);
  EXPECT_EQ(c, 2u);
  fx.add(0, Vec3{0.5, 0, 0}, Vec3{}, true);
  fx.add_pair(0, 1, Vec3{0, 3.0, 0}, Vec3{}, Vec3{});  // 3 N: 2^56.6 quanta, beyond 2^56
  for (std::uint32_t i : {0u, 1u}) {
    fx.take(i, f, t, c);
    EXPECT_TRUE(std::isnan(f.x) && std::isnan(f.y) && std::isnan(t.z)) << i;
    EXPECT_EQ(c, i == 0 ? 1u : 0u);
    fx.take(i, f, t, c);  // cleared
    EXPECT_EQ(f.x, 0.0);
    EXPECT_FALSE(std::isnan(f.y));
  }
}
