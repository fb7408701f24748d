// A [[wall]] entry of the case file as engine geometry (at t = 0; translation is applied by the
// engine from the wall's schedule). One place, used by the parser's overlap check and the builder.
#pragma once
#include "config/case_config.hpp"
#include "walls/wall_geometry.hpp"

namespace biodem::walls {

inline WallGeometry geometry_from_config(const config::Wall& w) {
  WallGeometry g;
  switch (w.kind) {
    case config::WallKind::Plane: g.kind = Kind::Plane; break;
    case config::WallKind::Disc: g.kind = Kind::Disc; break;
    case config::WallKind::Cylinder: g.kind = Kind::Cylinder; break;
    case config::WallKind::Rectangle: g.kind = Kind::Rectangle; break;
  }
  g.point_m = {w.point_m[0], w.point_m[1], w.point_m[2]};
  g.normal = normalized(Vec3{w.normal[0], w.normal[1], w.normal[2]});
  g.radius_m = w.radius_m;
  g.length_m = w.length_m;
  g.angular_velocity_rad_s = w.angular_velocity_rad_s;
  if (w.kind == config::WallKind::Rectangle) {
    // u is made exactly perpendicular to the normal (the parser accepts |u . n| <= 1e-6).
    const Vec3 u{w.u[0], w.u[1], w.u[2]};
    g.edge_u = normalized(u - dot(u, g.normal) * g.normal);
    g.half_u_m = 0.5 * w.size_m[0];
    g.half_v_m = 0.5 * w.size_m[1];
  }
  return g;
}

}  // namespace biodem::walls
