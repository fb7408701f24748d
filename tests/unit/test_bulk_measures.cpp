// Response measurements of the bulk tests on synthetic scenes of known answer (issues 9 and 20,
// SPEC 7): the heap's angle from sector fits, its spread, and the strays that must not count.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <vector>

#include "scenario/bulk_measures.hpp"

using namespace biodem;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

struct Scene {
  std::vector<Vec3> c;
  std::vector<double> r;
  std::vector<std::uint32_t> body;
  void add(const Vec3& x, double rad, std::uint32_t b) {
    c.push_back(x);
    r.push_back(rad);
    body.push_back(b);
  }
  void add(const Vec3& x, double rad) { add(x, rad, static_cast<std::uint32_t>(c.size())); }
};

/// A solid cone of spheres (radius r) on the plate y = 0, base radius R, slope theta_pos where
/// x > 0 and theta_neg where x <= 0: columns on a slightly jittered grid (touching neighbours),
/// spheres stacked where their top lies under the surface, plus one sphere per column touching
/// the surface from below (so every bin has its top there). Every sphere is its own body.
void cone(Scene& s, double theta_pos_deg, double theta_neg_deg, double R, double r) {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> jit(-0.04 * r, 0.04 * r);
  const double step = 2.0 * r;
  for (double x = -R; x <= R; x += step)
    for (double z = -R; z <= R; z += step) {
      const double px = x + jit(rng), pz = z + jit(rng), rho = std::hypot(px, pz);
      if (rho > R) continue;
      const double t = std::tan((px > 0.0 ? theta_pos_deg : theta_neg_deg) * kDeg);
      const double surface = t * (R - rho);
      for (double y = r; y + r <= surface; y += step) s.add({px, y, pz}, r);
      if (surface >= 2.0 * r) s.add({px, surface - r, pz}, r);  // the column's top touches the surface
    }
}

scenario::HeapResult measure(const Scene& s, std::size_t sectors = 8) {
  scenario::HeapOptions o;
  o.bin_m = 1e-3;
  o.sectors = sectors;
  return scenario::measure_heap(s.c, s.r, s.body, {0, 0, 0}, {0, 1, 0}, o);
}

}  // namespace

// Slopes 20, 30 and 40 degrees, 1 mm spheres, base radius 40 mm, 8 and 4 sectors: the mean within
// 0.5 degrees (measured within 0.05), every sector within 1 degree, so the spread is below 0.5; a
// wrong sign gives a negative angle, degrees/radians or a bin offset error show. Height within
// 1.5 mm, base radius within 1.5 bins, no strays.
TEST(HeapAngle, SyntheticConesOfKnownSlope) {
  for (double theta : {20.0, 30.0, 40.0})
    for (std::size_t sectors : {8u, 4u}) {
      Scene s;
      cone(s, theta, theta, 0.04, 0.5e-3);
      const auto h = measure(s, sectors);
      std::printf("[measured] cone of %.0f deg (%zu spheres, %zu sectors): angle %.3f +- %.3f deg, height %.4f m "
                  "(%.4f), base radius %.4f m, strays %zu\n",
                  theta, s.c.size(), sectors, h.angle_deg, h.angle_spread_deg, h.height_m, 0.04 * std::tan(theta * kDeg),
                  h.base_radius_m, h.stray_bodies);
      ASSERT_TRUE(h.valid);
      EXPECT_EQ(h.sectors_fitted, sectors);
      EXPECT_NEAR(h.angle_deg, theta, 0.5);
      EXPECT_LT(h.angle_spread_deg, 0.5);
      for (double a : h.sector_angle_deg) EXPECT_NEAR(a, theta, 1.0);
      EXPECT_NEAR(h.height_m, 0.04 * std::tan(theta * kDeg), 1.5e-3);
      // The base radius is where the heap stands two particle sizes high: R - 2 d / tan(theta).
      EXPECT_NEAR(h.base_radius_m, 0.04 - 2e-3 / std::tan(theta * kDeg), 1.5e-3);
      EXPECT_EQ(h.stray_bodies, 0u);
      EXPECT_EQ(h.heap_bodies, s.c.size());
    }
}

// A heap of two slopes, 30 degrees on the x > 0 side and 40 on the other: the sector fits see
// both, so the mean is near 35, min and max near 30 and 40, and the spread about 5 (sample
// standard deviation of four sectors at each slope: 5.3). One all-azimuth profile would only see
// the steeper side.
TEST(HeapAngle, SectorsSeeAnAsymmetricHeap) {
  Scene s;
  cone(s, 30.0, 40.0, 0.04, 0.5e-3);
  const auto h = measure(s);
  std::printf("[measured] 30/40 deg heap: mean %.3f, spread %.3f, min %.3f, max %.3f deg\n", h.angle_deg,
              h.angle_spread_deg, h.angle_min_deg, h.angle_max_deg);
  ASSERT_TRUE(h.valid);
  EXPECT_NEAR(h.angle_deg, 35.0, 1.0);
  EXPECT_NEAR(h.angle_min_deg, 30.0, 1.5);
  EXPECT_NEAR(h.angle_max_deg, 40.0, 1.5);
  EXPECT_NEAR(h.angle_spread_deg, 5.3, 1.0);
  // The spread is the sample standard deviation (n - 1) of the fitted sectors' angles, recomputed
  // here; with n the 5.3 would be 7 % lower, within the tolerance above.
  std::vector<double> fitted;
  for (double a : h.sector_angle_deg)
    if (std::isfinite(a)) fitted.push_back(a);
  ASSERT_GE(fitted.size(), 4u);
  double mean = 0.0, ss = 0.0;
  for (double a : fitted) mean += a / static_cast<double>(fitted.size());
  for (double a : fitted) ss += (a - mean) * (a - mean);
  EXPECT_NEAR(h.angle_spread_deg, std::sqrt(ss / static_cast<double>(fitted.size() - 1)), 1e-9);
  EXPECT_NEAR(h.angle_deg, mean, 1e-9);
}

// Strays (issue 20): a three-sphere needle held high up (as by the lifted cylinder, 160 mm above
// the plate), a two-needle cluster that rolled off onto the plate beyond the heap's foot, and a
// bead in flight beside the heap. None of them sets the height, the base radius or the angle,
// and the five stray bodies are counted.
TEST(HeapAngle, StraysSetNeitherHeightNorRadius) {
  Scene s;
  cone(s, 35.0, 35.0, 0.04, 0.5e-3);
  const std::size_t heap = s.c.size();
  const auto clean = measure(s);
  std::uint32_t id = 1000000;
  for (int k = -1; k <= 1; ++k) s.add({0.02 + 0.8e-3 * k, 0.16, 0.0}, 0.5e-3, id);  // needle up the tube
  ++id;
  for (int n = 0; n < 2; ++n, ++id)  // a cluster on the plate, 70 mm out: two touching needles
    for (int k = -1; k <= 1; ++k) s.add({0.07 + 0.8e-3 * k, 0.5e-3 + 0.99e-3 * n, 0.0}, 0.5e-3, id);
  s.add({-0.05, 0.03, 0.0}, 0.5e-3, id++);   // in flight
  s.add({0.0, -0.05, 0.07}, 0.5e-3, id++);   // fell below the plate (a sink will take it)
  const auto h = measure(s);
  std::printf("[measured] heap with 5 strays: angle %.3f (clean %.3f), height %.4f (clean %.4f), base %.4f "
              "(clean %.4f), strays %zu\n",
              h.angle_deg, clean.angle_deg, h.height_m, clean.height_m, h.base_radius_m, clean.base_radius_m,
              h.stray_bodies);
  ASSERT_TRUE(h.valid);
  EXPECT_EQ(h.stray_bodies, 5u);
  EXPECT_EQ(h.heap_bodies, heap);
  EXPECT_EQ(h.height_m, clean.height_m);
  EXPECT_EQ(h.base_radius_m, clean.base_radius_m);
  EXPECT_EQ(h.angle_deg, clean.angle_deg);
  EXPECT_LT(h.height_m, 0.04);  // the needle up the tube (0.1605 m) is not the summit
}

// Beads held in the lifted cylinder (a ring of 12 at y = 60 mm, above a 35-degree cone 28 mm
// high) are "lifted": more than a particle size above the heap's top. A stray on the plate and
// one resting on the heap's flank within a particle size of the top are not. With no heap on the
// plate at all, every body above one particle size is lifted (the driver warns: the rig held
// the bed, it did not flow flat).
TEST(HeapAngle, BodiesHeldAboveTheHeapAreLifted) {
  Scene s;
  cone(s, 35.0, 35.0, 0.04, 0.5e-3);
  const auto clean = measure(s);
  EXPECT_EQ(clean.lifted_bodies, 0u);
  std::uint32_t id = 1000000;
  for (int k = 0; k < 12; ++k) {
    const double a = 2.0 * std::numbers::pi * k / 12.0;
    s.add({0.0065 * std::cos(a), 0.06, 0.0065 * std::sin(a)}, 0.5e-3, id++);
  }
  s.add({0.07, 0.5e-3, 0.0}, 0.5e-3, id++);                     // rolled away on the plate
  // off the heap, its lowest point 0.5 mm above the top (within a particle size): not lifted
  s.add({0.0, clean.height_m + 1.0e-3, 0.03}, 0.5e-3, id++);
  const auto h = measure(s);
  ASSERT_TRUE(h.valid);
  EXPECT_EQ(h.height_m, clean.height_m);
  EXPECT_EQ(h.stray_bodies, 14u);
  EXPECT_EQ(h.lifted_bodies, 12u);
  Scene held;  // nothing reached the plate
  for (int k = 0; k < 12; ++k) held.add({1e-3 * k, 0.05, 0.0}, 0.4e-3);
  const auto none = measure(held);
  EXPECT_FALSE(none.valid);
  EXPECT_EQ(none.lifted_bodies, 12u);
}

// A flat monolayer (what frictionless spheres leave) is no heap: not valid, angle 0.
TEST(HeapAngle, MonolayerIsNoHeap) {
  Scene s;
  for (double x = -0.02; x <= 0.02; x += 1e-3)
    for (double z = -0.02; z <= 0.02; z += 1e-3) s.add({x, 0.5e-3, z}, 0.5e-3);
  const auto h = measure(s);
  EXPECT_FALSE(h.valid);
  EXPECT_EQ(h.angle_deg, 0.0);
}

// A crater (the surface rises away from the axis, 20 degrees) is no heap: the sector fits see
// -20 degrees, which must not be taken for an angle of repose (a sign error would report +20).
TEST(HeapAngle, CraterIsNoHeap) {
  Scene s;
  const double r = 0.5e-3, R = 0.02, t = std::tan(20.0 * kDeg), h0 = 4e-3;
  for (double x = -R; x <= R; x += 2.0 * r)
    for (double z = -R; z <= R; z += 2.0 * r) {
      const double rho = std::hypot(x, z);
      if (rho > R) continue;
      const double surface = h0 + t * rho;
      for (double y = r; y + r <= surface; y += 2.0 * r) s.add({x, y, z}, r);
      s.add({x, surface - r, z}, r);
    }
  const auto h = measure(s);
  EXPECT_FALSE(h.valid);
  EXPECT_EQ(h.angle_deg, 0.0);
  EXPECT_NEAR(h.angle_min_deg, -20.0, 1.5);  // the sector fits are kept for diagnosis
  EXPECT_NEAR(h.angle_max_deg, -20.0, 1.5);
  EXPECT_GE(h.sectors_fitted, 4u);
}

// Steep heaps on a small base (radius 4 mm, 1 mm bins: the fitted band, 0.6 of the base radius
// wide, spans 2 to 3 bins): sectors with fewer than 3 bins in the band take their slope from
// where the profile crosses the band's two levels. Before, they were not fitted and a steep heap
// scored 0 degrees (heap not found), as a flat bed does: the wrong way for a calibration. Within
// 6 degrees (the crossings are interpolated between bin centres of a coarse profile).
TEST(HeapAngle, SteepConesOnASmallBaseAreMeasured) {
  std::size_t steep = 0;  // (measured: 7 of 8 sectors at 55 and 60 degrees, none at 65 and 70)
  for (double theta : {55.0, 60.0, 65.0, 70.0}) {
    Scene s;
    cone(s, theta, theta, 4e-3, 0.25e-3);
    const auto h = measure(s);
    std::printf("[measured] steep cone of %.0f deg (%zu spheres): angle %.2f +- %.2f deg, %zu of %zu sectors from "
                "the band's crossings\n",
                theta, s.c.size(), h.angle_deg, h.angle_spread_deg, h.sectors_steep, h.sectors_fitted);
    ASSERT_TRUE(h.valid) << theta;
    EXPECT_NEAR(h.angle_deg, theta, 6.0);
    steep += h.sectors_steep;
  }
  EXPECT_GE(steep, 8u) << "the crossings' fallback is not exercised";
}
