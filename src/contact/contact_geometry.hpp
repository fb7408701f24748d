// The geometry and kinematics of one contact, computed once and handed to every sub-model
// (STYLE.md 3). Conventions: `normal` is the unit vector from body j (or the wall) to body i;
// `overlap_m` = R_i + R_j - distance (> 0 in contact); `v_rel` is the velocity of i's surface
// minus j's surface (or the wall's) at the contact point, including omega x r terms;
// `w_rel` = omega_i - omega_j (the wall's angular velocity for a wall).
#pragma once
#include "core/hd.hpp"
#include "core/lanes.hpp"

namespace biodem::contact {

/// R: double (vectors Vec3), or SIMD lanes of doubles, one contact per lane (core/lanes.hpp).
template <class R>
struct ContactGeometryT {
  vec3_t<R> normal{};
  R overlap_m = 0.0;
  R distance_m = 0.0;  // centre distance (pair) or centre-to-surface distance (wall)
  R r_eff_m = 0.0;     // R*
  R m_eff_kg = 0.0;    // m* (body masses)
  vec3_t<R> lever_i{};  // from the centre of sphere i to the contact point
  vec3_t<R> lever_j{};  // from the centre of sphere j to the contact point (unused for walls)
  vec3_t<R> v_rel{};
  vec3_t<R> w_rel{};
};
using ContactGeometry = ContactGeometryT<double>;

/// Sphere-sphere geometry. Contact point: the middle of the overlap along the normal, i.e. at
/// distance r_i - delta/2 from centre i.
template <class R>
BIODEM_HD inline ContactGeometryT<R> sphere_sphere_geometry(const vec3_t<R>& d_ij, R dist, R r_i, R r_j, R m_i, R m_j,
                                                            const vec3_t<R>& v_i, const vec3_t<R>& v_j,
                                                            const vec3_t<R>& w_i, const vec3_t<R>& w_j) {
  ContactGeometryT<R> g;
  g.distance_m = dist;
  g.normal = d_ij / dist;
  g.overlap_m = r_i + r_j - dist;
  g.r_eff_m = r_i * r_j / (r_i + r_j);
  g.m_eff_kg = m_i * m_j / (m_i + m_j);
  g.lever_i = -(r_i - 0.5 * g.overlap_m) * g.normal;
  g.lever_j = (r_j - 0.5 * g.overlap_m) * g.normal;
  g.v_rel = (v_i + cross(w_i, g.lever_i)) - (v_j + cross(w_j, g.lever_j));
  g.w_rel = w_i - w_j;
  return g;
}

/// Sphere-wall geometry: R_j, m_j -> infinity, so R* = r_i and m* = m_i. `gap` is the distance
/// from the sphere centre to the wall surface along `normal`; `v_wall`/`w_wall` the wall's
/// surface velocity at the contact point and its angular velocity.
template <class R>
BIODEM_HD inline ContactGeometryT<R> sphere_wall_geometry(const vec3_t<R>& normal, R gap, R r_i, R m_i,
                                                          const vec3_t<R>& v_i, const vec3_t<R>& w_i,
                                                          const vec3_t<R>& v_wall, const vec3_t<R>& w_wall) {
  ContactGeometryT<R> g;
  g.distance_m = gap;
  g.normal = normal;
  g.overlap_m = r_i - gap;
  g.r_eff_m = r_i;
  g.m_eff_kg = m_i;
  g.lever_i = -(r_i - 0.5 * g.overlap_m) * normal;
  g.v_rel = v_i + cross(w_i, g.lever_i) - v_wall;
  g.w_rel = w_i - w_wall;
  return g;
}

}  // namespace biodem::contact
