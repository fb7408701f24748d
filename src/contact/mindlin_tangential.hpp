// Mindlin tangential force with history and the Coulomb limit (SPEC 2.2; Mindlin 1949;
// LIGGGHTS 3.8.0 `tangential history`):
//     k_t = 8 G* sqrt(R* delta)
//     xi += v_t dt, then xi -= (xi . n) n      (kept in the tangent plane, length not rescaled)
//     if |k_t xi| > mu |F_n|:  F_t = -mu |F_n| xi/|xi| (no damping while sliding), xi = -F_t / k_t
//     else                     F_t = -k_t xi - gamma_t v_t
// F_n is the scalar normal force of Hertz + damping, cohesion not subtracted (SPEC 2.2, LIGGGHTS
// 3.8.0 default); contact_model.hpp chooses it (or the reduced force with tangential_reduce).
#pragma once
#include "core/hd.hpp"
#include <cmath>

#include "core/vec3.hpp"

namespace biodem::contact {

BIODEM_HD inline double mindlin_tangential_stiffness(double g_eff_pa, double r_eff_m, double overlap_m) {
  return 8.0 * g_eff_pa * std::sqrt(r_eff_m * overlap_m);
}

struct TangentialResult {
  Vec3 force;  // on body i
  bool sliding = false;
};

/// Updates the history `xi` in place and returns the tangential force on i.
BIODEM_HD inline TangentialResult mindlin_tangential_force(Vec3& xi, const Vec3& v_t, const Vec3& n, double k_t,
                                                 double gamma_t, double friction, double normal_force_abs,
                                                 double dt) {
  xi += v_t * dt;
  xi -= dot(xi, n) * n;
  TangentialResult r;
  const Vec3 spring = -k_t * xi;
  const double limit = friction * normal_force_abs;
  const double spring2 = norm2(spring);
  if (spring2 > limit * limit) {
    r.sliding = true;
    r.force = spring * (limit / std::sqrt(spring2));
    xi = r.force * (-1.0 / k_t);
  } else {
    r.force = spring - gamma_t * v_t;
  }
  return r;
}

}  // namespace biodem::contact
