// Analytic wall geometry (STYLE.md 4): each wall answers "where is the nearest surface point
// to a sphere centre, along which normal, and how deep is the overlap", producing the same
// contact geometry as a particle pair so that the same force laws apply. Pure functions.
//
// Sign conventions: the normal n points from the wall into the particle side; the overlap is
// delta = r - gap, positive in contact; the wall surface point is centre - gap * n.
#pragma once
#include "core/hd.hpp"
#include <cmath>

#include "core/vec3.hpp"

namespace biodem::walls {

enum class Kind { Plane, Disc, Cylinder };

struct WallGeometry {
  Kind kind = Kind::Plane;
  Vec3 point_m;            // plane/disc: point on the surface (disc centre); cylinder: point on the axis
  Vec3 normal{0, 0, 1};    // plane/disc: unit normal to the particle side; cylinder: unit axis
  double radius_m = 0.0;   // disc, cylinder
  double length_m = 0.0;   // cylinder: finite extent from point_m along the axis (0 = infinite)
  double angular_velocity_rad_s = 0.0;  // prescribed rotation about the symmetry axis (point_m, normal)
};

struct WallHit {
  bool touching = false;
  double gap_m = 0.0;   // distance from the sphere centre to the surface along n (>= 0 on the particle side)
  Vec3 normal;          // from wall to particle
};

/// Distance of a sphere centre to the wall surface and the contact normal. For the inside of a
/// cylinder the particle side is the inside; for a disc, points whose projection falls outside
/// the disc radius do not touch (the rim is not modelled).
BIODEM_HD inline WallHit wall_hit(const WallGeometry& w, const Vec3& c, double r) {
  WallHit h;
  switch (w.kind) {
    case Kind::Plane:
    case Kind::Disc: {
      const Vec3 d = c - w.point_m;
      h.gap_m = dot(d, w.normal);
      h.normal = w.normal;
      if (w.kind == Kind::Disc) {
        const Vec3 radial = d - h.gap_m * w.normal;
        if (norm2(radial) > w.radius_m * w.radius_m) return h;
      }
      h.touching = h.gap_m < r && h.gap_m > -r;  // sphere centre behind the wall by more than r: no contact
      return h;
    }
    case Kind::Cylinder: {
      const Vec3 d = c - w.point_m;
      const double axial = dot(d, w.normal);
      if (w.length_m > 0.0 && (axial < 0.0 || axial > w.length_m)) return h;
      const Vec3 radial = d - axial * w.normal;
      const double rho = norm(radial);
      h.gap_m = w.radius_m - rho;
      h.normal = rho > 0.0 ? radial / (-rho) : Vec3{};
      h.touching = h.gap_m < r && rho > 0.0;
      return h;
    }
  }
  return h;
}

/// Surface velocity of the wall at point p: omega x (p - axis point), omega along the symmetry axis.
BIODEM_HD inline Vec3 wall_velocity(const WallGeometry& w, const Vec3& p) {
  if (w.angular_velocity_rad_s == 0.0) return {};
  return cross(w.angular_velocity_rad_s * w.normal, p - w.point_m);
}

}  // namespace biodem::walls
