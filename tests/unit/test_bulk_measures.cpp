// Response measurements of the bulk tests on synthetic scenes of known answer (issue 9, SPEC 7).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

#include "scenario/bulk_measures.hpp"

using namespace biodem;

namespace {

/// A solid cone of spheres (radius r) of slope theta and base radius R on the plate y = 0:
/// spheres on a jittered grid, kept where their top lies under the cone surface, plus one
/// sphere per grid column touching the surface from below (so every bin has its top there).
void cone(double theta_deg, double R, double r, std::vector<Vec3>& c, std::vector<double>& rad) {
  const double t = std::tan(theta_deg * std::numbers::pi / 180.0), H = R * t;
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> jit(-0.3 * r, 0.3 * r);
  const double s = 2.0 * r;
  for (double x = -R; x <= R; x += s)
    for (double z = -R; z <= R; z += s) {
      const double px = x + jit(rng), pz = z + jit(rng), rho = std::hypot(px, pz);
      if (rho > R) continue;
      const double surface = H - t * rho;
      for (double y = r; y + r <= surface; y += s) {
        c.push_back({px, y, pz});
        rad.push_back(r);
      }
      if (surface >= 2.0 * r) {  // the column's top sphere touches the surface
        c.push_back({px, surface - r, pz});
        rad.push_back(r);
      }
    }
}

}  // namespace

// Slopes 20, 30 and 40 degrees, 1 mm spheres, base radius 40 mm: within 0.5 degrees (the issue's
// tolerance; measured within 0.01 degrees); a wrong sign gives a negative angle, degrees/radians
// or a bin offset error show. Height within 1.5 mm, base radius within 1.5 bins.
TEST(HeapAngle, SyntheticConesOfKnownSlope) {
  for (double theta : {20.0, 30.0, 40.0}) {
    std::vector<Vec3> c;
    std::vector<double> r;
    cone(theta, 0.04, 0.5e-3, c, r);
    const auto h = scenario::measure_heap(c, r, {0, 0, 0}, {0, 1, 0}, 1e-3);
    std::printf("[measured] cone of %.0f deg (%zu spheres): angle %.3f deg, height %.4f m (%.4f), base radius %.4f m\n",
                theta, c.size(), h.angle_deg, h.height_m, 0.04 * std::tan(theta * std::numbers::pi / 180.0),
                h.base_radius_m);
    ASSERT_TRUE(h.valid);
    EXPECT_NEAR(h.angle_deg, theta, 0.5);
    EXPECT_NEAR(h.height_m, 0.04 * std::tan(theta * std::numbers::pi / 180.0), 1.5e-3);
    // The base radius is where the heap stands two particle sizes high: R - 2 d / tan(theta).
    EXPECT_NEAR(h.base_radius_m, 0.04 - 2e-3 / std::tan(theta * std::numbers::pi / 180.0), 1.5e-3);
  }
}

// A flat monolayer (what frictionless spheres leave) is no heap: not valid, angle 0.
TEST(HeapAngle, MonolayerIsNoHeap) {
  std::vector<Vec3> c;
  std::vector<double> r;
  for (double x = -0.02; x <= 0.02; x += 1e-3)
    for (double z = -0.02; z <= 0.02; z += 1e-3) {
      c.push_back({x, 0.5e-3, z});
      r.push_back(0.5e-3);
    }
  const auto h = scenario::measure_heap(c, r, {0, 0, 0}, {0, 1, 0}, 1e-3);
  EXPECT_FALSE(h.valid);
  EXPECT_EQ(h.angle_deg, 0.0);
}
