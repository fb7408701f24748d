// Clump templates and needle geometry (SPEC 3) against analytical values.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "shapes/clump_template.hpp"
#include "shapes/mass_properties.hpp"

using namespace biodem;

TEST(NeedleGeometry, RawBiomassMatchesPublishedClumpTable) {
  const auto g = shapes::needle_geometry(746e-6, 0.38, 0.2);
  EXPECT_EQ(g.n_spheres, 3);
  EXPECT_NEAR(g.length_m / 1940e-6, 1.0, 2e-3);
  EXPECT_NEAR(g.volume_m3 / 0.6282e-9, 1.0, 2e-3);
  EXPECT_NEAR(g.equivalent_diameter_m / 1062e-6, 1.0, 2e-3);
}

TEST(NeedleGeometry, IntensivelyTorrefiedMatchesPublishedClumpTable) {
  const auto g = shapes::needle_geometry(526e-6, 0.41, 0.2);
  EXPECT_EQ(g.n_spheres, 3);
  EXPECT_NEAR(g.length_m / 1367e-6, 1.0, 2e-3);
  EXPECT_NEAR(g.volume_m3 / 0.2199e-9, 1.0, 2e-3);
  EXPECT_NEAR(g.equivalent_diameter_m / 748e-6, 1.0, 2e-3);
}

TEST(NeedleGeometry, MildlyTorrefiedFollowsEquationsNotThePrintedColumn) {
  const auto g = shapes::needle_geometry(667e-6, 0.31, 0.2);
  EXPECT_EQ(g.n_spheres, 4);
  EXPECT_NEAR(g.length_m / 2268e-6, 1.0, 1e-3);
  EXPECT_NEAR(g.volume_m3 / 0.5954e-9, 1.0, 1e-3);
  EXPECT_NEAR(g.equivalent_diameter_m / 1044e-6, 1.0, 1e-3);
}

TEST(MassProperties, SingleSphereInertiaIsTwoFifthsMR2) {
  const double r = 1.3e-3;
  const auto mp = shapes::union_of_spheres({Vec3{0.1, -0.2, 0.3}}, {r});
  const double v = 4.0 / 3.0 * std::numbers::pi * r * r * r;
  EXPECT_NEAR(mp.volume_m3 / v, 1.0, 1e-12);
  const Mat3 i = mp.inertia_about_centroid_m5();
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(i(k, k) / (0.4 * v * r * r), 1.0, 1e-6);
  EXPECT_NEAR(i(0, 1), 0.0, 1e-6 * v * r * r);
}

TEST(MassProperties, TwoOverlappingSpheresMatchLensCorrectedAnalyticValue) {
  // Two equal spheres radius r at distance d: union volume and inertia by hand-computed formulas.
  const double r = 1.0, d = 1.6;  // overlap factor c = 0.2
  const auto mp = shapes::union_of_spheres({Vec3{-d / 2, 0, 0}, Vec3{d / 2, 0, 0}}, {r, r});
  const double h = r - d / 2;  // cap height
  const double v_cap = std::numbers::pi * h * h * (3 * r - h) / 3.0;
  const double v_expect = 2 * (4.0 / 3.0 * std::numbers::pi) - 2 * v_cap;
  EXPECT_NEAR(mp.volume_m3 / v_expect, 1.0, 1e-12);
  // Independent check: converged grid integration.
  const auto num = shapes::union_of_spheres_numerical({Vec3{-d / 2, 0, 0}, Vec3{d / 2, 0, 0}}, {r, r}, 300);
  const Mat3 ie = mp.inertia_about_centroid_m5(), in = num.inertia_about_centroid_m5();
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(ie(k, k) / in(k, k), 1.0, 5e-3);
  EXPECT_NEAR(num.volume_m3 / v_expect, 1.0, 5e-3);
  // Axial moment of a union symmetric about the x axis: 2 * (sphere axial - cap axial),
  // cap axial moment = pi h^3 (3h^2 - 15 r h + 20 r^2) / 30.
  const double i_axial = 2 * (0.4 * (4.0 / 3.0 * std::numbers::pi) * r * r -
                              std::numbers::pi * h * h * h * (3 * h * h - 15 * r * h + 20 * r * r) / 30.0);
  EXPECT_NEAR(ie(0, 0) / i_axial, 1.0, 1e-10);
}

TEST(ClumpTemplate, NeedleIsCentredAndAlongPrincipalAxes) {
  config::Shape s;
  s.name = "raw";
  s.kind = config::ShapeKind::Needle;
  s.d50_m = 746e-6;
  s.aspect_ratio = 0.38;
  s.overlap_factor = 0.2;
  const auto t = shapes::make_template(s, 4.0);
  ASSERT_EQ(t.sphere_count(), 3u);
  EXPECT_NEAR(t.radii_m[0], 2 * 746e-6, 1e-12);
  const auto g = shapes::needle_geometry(4 * 746e-6, 0.38, 0.2);
  EXPECT_NEAR(t.volume_m3 / g.volume_m3, 1.0, 1e-10);
  // Smallest principal moment is about the long axis, so the long axis is the first body axis.
  Vec3 sum;
  for (const auto& o : t.offsets_m) sum += o;
  EXPECT_NEAR(norm(sum), 0.0, 1e-12);
  EXPECT_NEAR(std::abs(t.offsets_m[0].x), 0.8 * 4 * 746e-6, 1e-9);
  EXPECT_NEAR(t.offsets_m[0].y, 0.0, 1e-12);
  EXPECT_LT(t.principal_inertia_per_density_m5.x, t.principal_inertia_per_density_m5.y);
}
