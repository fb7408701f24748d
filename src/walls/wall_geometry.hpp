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

enum class Kind { Plane, Disc, Cylinder, Rectangle };

struct WallGeometry {
  Kind kind = Kind::Plane;
  Vec3 point_m;            // plane/disc: point on the surface (disc centre); cylinder: point on the axis
  Vec3 normal{0, 0, 1};    // plane/disc: unit normal to the particle side; cylinder: unit axis
  double radius_m = 0.0;   // disc, cylinder
  double length_m = 0.0;   // cylinder: finite extent from point_m along the axis (0 = infinite)
  double angular_velocity_rad_s = 0.0;  // prescribed rotation about the symmetry axis (point_m, normal)
  // Rectangle: a finite plate centred on point_m, sides 2 half_u_m along edge_u and 2 half_v_m
  // along normal x edge_u (edge_u is a unit vector perpendicular to normal).
  Vec3 edge_u{1, 0, 0};
  double half_u_m = 0.0, half_v_m = 0.0;
  // Current prescribed translation velocity (the engine sets it from the wall's motion schedule
  // and moves point_m; zero for a wall at rest).
  Vec3 velocity_m_s;
};

struct WallHit {
  bool touching = false;
  double gap_m = 0.0;   // distance from the sphere centre to the surface along n (>= 0 on the particle side)
  Vec3 normal;          // from wall to particle
};

/// Contact with the nearest point q of a thin plate (disc or rectangle), from either side: the
/// overlap is r - |c - q|, continuous over the face, its rim or edges and the back, so that a
/// sphere reaching the plate anywhere is pushed away from the point it touches.
BIODEM_HD inline WallHit plate_hit(const Vec3& c, double r, const Vec3& q, const Vec3& face_normal, double gap) {
  WallHit h;
  const Vec3 dq = c - q;
  const double g = norm(dq);
  if (!(g < r)) return h;
  h.gap_m = g;
  // (a centre in the plate itself: pushed to the side it came from is unknown; the face normal)
  h.normal = g > 0.0 ? dq / g : (gap < 0.0 ? -face_normal : face_normal);
  h.touching = true;
  return h;
}

/// Distance of a sphere centre to the wall surface and the contact normal. A plane has a particle
/// side (a centre behind it by less than r is pushed back). For the inside of an infinite
/// cylinder (length_m = 0, the drum mantle) the particle side is the inside; a finite cylinder
/// (length_m > 0) is an open thin tube touched from whichever side the centre is on (inside or
/// outside), so a lifted tube never drags outside particles in; beyond an end of a finite
/// cylinder a sphere touches the rim circle (nearest point on it). A disc or a rectangle is a
/// thin plate touched from either side at its nearest point: on the face, along the normal; past
/// the rim or an edge, at the rim or edge (before 2026-11-28 a disc was one-sided and neither had
/// rims or edges: a sphere sliding under a rim, or past an edge, met an overlap of up to 2 r at
/// once and was flung off with energy it never had).
BIODEM_HD inline WallHit wall_hit(const WallGeometry& w, const Vec3& c, double r) {
  WallHit h;
  switch (w.kind) {
    case Kind::Plane: {
      const Vec3 d = c - w.point_m;
      h.gap_m = dot(d, w.normal);
      h.normal = w.normal;
      h.touching = h.gap_m < r && h.gap_m > -r;  // sphere centre behind the wall by more than r: no contact
      return h;
    }
    case Kind::Disc: {
      const Vec3 d = c - w.point_m;
      const double g = dot(d, w.normal);
      const Vec3 radial = d - g * w.normal;
      const double rho2 = norm2(radial);
      if (rho2 <= w.radius_m * w.radius_m) {  // over the face: the projection
        if (!(g < r && g > -r)) return h;
        h.gap_m = g < 0.0 ? -g : g;
        h.normal = g < 0.0 ? -w.normal : w.normal;
        h.touching = true;
        return h;
      }
      return plate_hit(c, r, w.point_m + (w.radius_m / std::sqrt(rho2)) * radial, w.normal, g);
    }
    case Kind::Cylinder: {
      const Vec3 d = c - w.point_m;
      const double axial = dot(d, w.normal);
      const Vec3 radial = d - axial * w.normal;
      const double rho = norm(radial);
      if (w.length_m > 0.0 && (axial < 0.0 || axial > w.length_m)) {
        // Beyond an end of a finite tube: contact with the nearest point of its rim circle, so
        // that a sphere landing on the rim is pushed off it instead of being flung through the
        // wall when its centre passes the end (the overlap is continuous across the end).
        if (!(rho > 0.0)) return h;
        const double a_end = axial < 0.0 ? 0.0 : w.length_m;
        const Vec3 q = w.point_m + a_end * w.normal + (w.radius_m / rho) * radial;
        const Vec3 dq = c - q;
        const double g = norm(dq);
        if (!(g > 0.0) || g >= r) return h;
        h.gap_m = g;
        h.normal = dq / g;
        h.touching = true;
        return h;
      }
      h.gap_m = w.radius_m - rho;
      h.normal = rho > 0.0 ? radial / (-rho) : Vec3{};
      if (w.length_m > 0.0 && h.gap_m < 0.0) {  // outside a finite tube: pushed outwards
        h.gap_m = -h.gap_m;
        h.normal = -h.normal;
      }
      h.touching = h.gap_m < r && rho > 0.0;
      return h;
    }
    case Kind::Rectangle: {
      const Vec3 d = c - w.point_m;
      const double g = dot(d, w.normal);
      const Vec3 edge_v = cross(w.normal, w.edge_u);
      const double u = dot(d, w.edge_u), v = dot(d, edge_v);
      if (u <= w.half_u_m && u >= -w.half_u_m && v <= w.half_v_m && v >= -w.half_v_m) {  // over the face
        h.gap_m = g < 0.0 ? -g : g;
        h.normal = g < 0.0 ? -w.normal : w.normal;
        h.touching = h.gap_m < r;
        return h;
      }
      const double uc = u > w.half_u_m ? w.half_u_m : (u < -w.half_u_m ? -w.half_u_m : u);
      const double vc = v > w.half_v_m ? w.half_v_m : (v < -w.half_v_m ? -w.half_v_m : v);
      return plate_hit(c, r, w.point_m + uc * w.edge_u + vc * edge_v, w.normal, g);
    }
  }
  return h;
}

/// Surface velocity of the wall at point p: its translation velocity plus omega x (p - axis
/// point), omega along the symmetry axis.
BIODEM_HD inline Vec3 wall_velocity(const WallGeometry& w, const Vec3& p) {
  if (w.angular_velocity_rad_s == 0.0) return w.velocity_m_s;
  return w.velocity_m_s + cross(w.angular_velocity_rad_s * w.normal, p - w.point_m);
}

/// Whether a sphere at c may touch the (fixed or turning) wall w before the next neighbour-list
/// build, `reach` being its radius plus the skin: the wall enlarged by the reach (a disc's radius,
/// a rectangle's half sides, a finite cylinder's ends), so that a sphere sliding over a disc rim
/// or a tube end is still one, within reach of it. Its centre moves less than half the skin
/// between builds, so a sphere out of reach at a build cannot touch the wall before the next.
/// (A translating wall may come to any sphere: the callers take it as within reach of all.)
BIODEM_HD inline bool within_reach(WallGeometry g, const Vec3& c, double reach) {
  if (g.kind == Kind::Disc) g.radius_m += reach;
  if (g.kind == Kind::Rectangle) {
    g.half_u_m += reach;
    g.half_v_m += reach;
  }
  if (g.kind == Kind::Cylinder && g.length_m > 0.0) {
    g.point_m -= reach * g.normal;
    g.length_m += 2.0 * reach;
  }
  return wall_hit(g, c, reach).touching;
}

}  // namespace biodem::walls
