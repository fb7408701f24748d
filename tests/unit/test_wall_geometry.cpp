// Finite walls (issue 9): the rectangle is a thin plate touched from either side within its
// sides; the finite cylinder is an open thin tube touched from inside and outside; translation
// velocity adds to the surface velocity.
#include <gtest/gtest.h>

#include <cmath>

#include "walls/wall_geometry.hpp"
#include "walls/wall_translation.hpp"

using namespace biodem;
using namespace biodem::walls;

TEST(WallGeometry, RectangleBothSidesWithinItsSides) {
  WallGeometry g;
  g.kind = Kind::Rectangle;
  g.point_m = {1, 2, 3};
  g.normal = {0, 0, 1};
  g.edge_u = {1, 0, 0};
  g.half_u_m = 0.5;  // x in [0.5, 1.5]
  g.half_v_m = 0.1;  // y in [1.9, 2.1] (v = n x u = +y)
  WallHit h = wall_hit(g, {1.4, 2.05, 3.3}, 0.4);
  EXPECT_TRUE(h.touching);
  EXPECT_NEAR(h.gap_m, 0.3, 1e-12);
  EXPECT_NEAR(h.normal.z, 1.0, 1e-15);
  h = wall_hit(g, {1.4, 2.05, 2.8}, 0.4);  // below: pushed down
  EXPECT_TRUE(h.touching);
  EXPECT_NEAR(h.gap_m, 0.2, 1e-12);
  EXPECT_NEAR(h.normal.z, -1.0, 1e-15);
  // Past a side: contact with the nearest edge point (before 2026-11-28: none, and then the whole
  // face overlap at once when the centre crossed the edge).
  h = wall_hit(g, {1.6, 2.0, 3.1}, 0.4);  // 0.1 beyond the u side, 0.1 above: edge point (1.5, 2.0, 3)
  EXPECT_TRUE(h.touching);
  EXPECT_NEAR(h.gap_m, std::sqrt(0.02), 1e-12);
  EXPECT_NEAR(h.normal.x, std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(h.normal.z, std::sqrt(0.5), 1e-12);
  h = wall_hit(g, {1.0, 2.15, 2.9}, 0.4);  // beyond the v side, below
  EXPECT_TRUE(h.touching);
  EXPECT_NEAR(h.gap_m, std::sqrt(0.05 * 0.05 + 0.01), 1e-12);
  EXPECT_LT(h.normal.z, 0.0);
  h = wall_hit(g, {1.7, 2.3, 3.1}, 0.4);  // beyond a corner: the corner (1.5, 2.1, 3)
  EXPECT_TRUE(h.touching);
  EXPECT_NEAR(h.gap_m, std::sqrt(0.04 + 0.04 + 0.01), 1e-12);
  EXPECT_FALSE(wall_hit(g, {1.95, 2.0, 3.0}, 0.4).touching);  // 0.45 beyond the u side, in the plane
  EXPECT_FALSE(wall_hit(g, {1.0, 2.0, 3.5}, 0.4).touching);   // too far
}

// A sphere passing a plate's rim or edge sees its overlap change continuously (no jump that would
// fling it off with energy it never had): a disc approached from behind and from the side, a
// rectangle edge crossed on the face side and on the back.
TEST(WallGeometry, PlateOverlapIsContinuousOverRimsEdgesAndBothFaces) {
  WallGeometry disc;
  disc.kind = Kind::Disc;
  disc.point_m = {0, 0, 0};
  disc.normal = {0, 1, 0};
  disc.radius_m = 3e-3;
  WallGeometry rect;
  rect.kind = Kind::Rectangle;
  rect.point_m = {0, 0, 0};
  rect.normal = {0, 1, 0};
  rect.edge_u = {1, 0, 0};
  rect.half_u_m = 3e-3;
  rect.half_v_m = 3e-3;
  const double r = 0.5e-3;
  for (const WallGeometry* g : {&disc, &rect})
    for (const double y : {-0.3e-3, 0.3e-3, -0.45e-3, 0.05e-3}) {
      double last = -1.0;
      for (int k = 0; k <= 2000; ++k) {  // x from 3.6 mm in to 2.4 mm, 0.6 um a step
        const double x = 3.6e-3 - 0.6e-6 * k;
        const WallHit h = wall_hit(*g, {x, y, 0.0}, r);
        const double overlap = h.touching ? r - h.gap_m : 0.0;
        if (last >= 0.0) {
          EXPECT_LT(std::abs(overlap - last), 1e-6) << "x " << x << " y " << y;
        }
        last = overlap;
        if (h.touching) {
          EXPECT_GT(h.normal.y * y, 0.0) << "pushed away from the plate, x " << x << " y " << y;
        }
      }
      EXPECT_NEAR(last, r - std::abs(y), 1e-15);  // over the face at the end
    }
}

// Plane: gap = (c - p).n along n on the particle side; a centre behind the plane by less than r
// still touches (pushed back out), by more it does not (one-sided wall). Disc: a thin plate,
// touched on either face within its radius and at its rim beyond it.
TEST(WallGeometry, PlaneIsOneSidedAndDiscEndsAtItsRim) {
  WallGeometry g;
  g.kind = Kind::Plane;
  g.point_m = {0, 1, 0};
  g.normal = {0, 1, 0};
  WallHit h = wall_hit(g, {5.0, 1.3, -7.0}, 0.4);  // anywhere along the plane
  EXPECT_TRUE(h.touching);
  EXPECT_NEAR(h.gap_m, 0.3, 1e-12);
  EXPECT_NEAR(h.normal.y, 1.0, 1e-15);
  EXPECT_FALSE(wall_hit(g, {0.0, 1.45, 0.0}, 0.4).touching);  // gap 0.45 > r
  h = wall_hit(g, {0.0, 0.8, 0.0}, 0.4);                      // 0.2 behind: overlap 0.6, pushed along +n
  EXPECT_TRUE(h.touching);
  EXPECT_NEAR(h.gap_m, -0.2, 1e-12);
  EXPECT_NEAR(h.normal.y, 1.0, 1e-15);
  EXPECT_FALSE(wall_hit(g, {0.0, 0.5, 0.0}, 0.4).touching);  // 0.5 behind, more than r: the other side

  g.kind = Kind::Disc;
  g.radius_m = 2.0;
  h = wall_hit(g, {1.2, 1.3, 1.5}, 0.4);  // projection at radius 1.92 < 2
  EXPECT_TRUE(h.touching);
  EXPECT_NEAR(h.gap_m, 0.3, 1e-12);
  h = wall_hit(g, {1.5, 1.3, 1.5}, 0.4);  // projection at radius 2.121 > 2: the rim point
  EXPECT_TRUE(h.touching);
  const double out = std::sqrt(1.5 * 1.5 + 1.5 * 1.5) - 2.0;
  EXPECT_NEAR(h.gap_m, std::sqrt(out * out + 0.09), 1e-12);
  EXPECT_GT(h.normal.x, 0.0);
  EXPECT_GT(h.normal.y, 0.0);
  EXPECT_FALSE(wall_hit(g, {1.8, 1.3, 1.8}, 0.4).touching);  // rim point 0.55 away
  h = wall_hit(g, {0.0, 0.8, 0.0}, 0.4);                     // 0.2 behind: touched from the back
  EXPECT_TRUE(h.touching);
  EXPECT_NEAR(h.gap_m, 0.2, 1e-12);
  EXPECT_NEAR(h.normal.y, -1.0, 1e-15);
  EXPECT_FALSE(wall_hit(g, {0.0, 0.5, 0.0}, 0.4).touching);  // behind by more than r
}

TEST(WallGeometry, FiniteTubeTouchedFromInsideAndOutside) {
  WallGeometry g;
  g.kind = Kind::Cylinder;
  g.point_m = {0, 1, 0};
  g.normal = {0, 1, 0};
  g.radius_m = 1.0;
  g.length_m = 2.0;
  WallHit h = wall_hit(g, {0.8, 2.0, 0.0}, 0.3);  // inside, 0.2 from the wall
  EXPECT_TRUE(h.touching);
  EXPECT_NEAR(h.gap_m, 0.2, 1e-12);
  EXPECT_NEAR(h.normal.x, -1.0, 1e-15);
  h = wall_hit(g, {0.0, 2.0, -1.1}, 0.3);  // outside, 0.1 from the wall
  EXPECT_TRUE(h.touching);
  EXPECT_NEAR(h.gap_m, 0.1, 1e-12);
  EXPECT_NEAR(h.normal.z, -1.0, 1e-15);
  EXPECT_FALSE(wall_hit(g, {0.5, 0.9, 0.0}, 0.3).touching);  // below its lower end, 0.51 from the rim
  EXPECT_FALSE(wall_hit(g, {0.5, 3.1, 0.0}, 0.3).touching);  // above its upper end, off the rim
  h = wall_hit(g, {1.0, 3.2, 0.0}, 0.3);                      // resting on the upper rim
  EXPECT_TRUE(h.touching);
  EXPECT_NEAR(h.gap_m, 0.2, 1e-12);
  EXPECT_NEAR(h.normal.y, 1.0, 1e-15);
  h = wall_hit(g, {1.0 + 0.3, 1.0 - 0.4, 0.0}, 0.6);         // below the lower rim, 0.5 away on a 3-4-5 line
  EXPECT_TRUE(h.touching);
  EXPECT_NEAR(h.gap_m, 0.5, 1e-12);
  EXPECT_NEAR(h.normal.x, 0.6, 1e-12);
  EXPECT_NEAR(h.normal.y, -0.8, 1e-12);
  g.length_m = 0.0;  // infinite (drum mantle): inside only, as before
  h = wall_hit(g, {0.0, 2.0, -1.1}, 0.3);
  EXPECT_TRUE(h.touching);
  EXPECT_NEAR(h.gap_m, -0.1, 1e-12);
}

TEST(WallGeometry, TranslationAddsToSurfaceVelocity) {
  WallGeometry g;
  g.kind = Kind::Plane;
  g.normal = {0, 0, 1};
  g.velocity_m_s = {0.0, 0.0, 0.2};
  EXPECT_EQ(wall_velocity(g, {1, 0, 0}).z, 0.2);
  g.angular_velocity_rad_s = 2.0;  // omega z x (1, 0, 0) = (0, 2, 0)
  const Vec3 v = wall_velocity(g, {1, 0, 0});
  EXPECT_NEAR(v.y, 2.0, 1e-15);
  EXPECT_NEAR(v.z, 0.2, 1e-15);
}

// A prescribed translation (walls/wall_translation.hpp, both engines): at rest at the initial
// point before the start, moved by (t - start) v while it moves, at rest at the end point after;
// the surface velocity is v from the start (included) to the end (excluded). A sign or a factor
// of 2 on the time moved puts the point 0.02 m off at t = 0.4 s.
TEST(WallTranslation, PlacedByItsScheduleBeforeDuringAndAfter) {
  const WallTranslation m{{0.0, 1.0, 0.0}, {0.0, 0.05, 0.0}, 0.2, 0.6};
  WallGeometry g;
  struct At {
    double t, y, vy;
  };
  for (const At& a : {At{0.1, 1.0, 0.0}, At{0.2, 1.0, 0.05}, At{0.4, 1.01, 0.05}, At{0.6, 1.02, 0.0}, At{0.9, 1.02, 0.0}}) {
    place_translating_wall(g, m, a.t);
    EXPECT_NEAR(g.point_m.y, a.y, 1e-15) << "t = " << a.t;
    EXPECT_EQ(g.point_m.x, 0.0);
    EXPECT_EQ(g.velocity_m_s.y, a.vy) << "t = " << a.t;
  }
  const WallTranslation down{{0.0, 1.0, 0.0}, {0.0, -0.05, 0.0}, 0.2, 0.6};
  place_translating_wall(g, down, 0.4);
  EXPECT_NEAR(g.point_m.y, 0.99, 1e-15);
  EXPECT_EQ(g.velocity_m_s.y, -0.05);
}
