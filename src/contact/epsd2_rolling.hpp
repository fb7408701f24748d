// EPSD2 rolling resistance: elastic-plastic spring, no dashpot (SPEC 2.3; Iwashita & Oda 1998;
// Ai, Chen, Rotter & Ooi, Powder Technol. 206 (2011) 269, model type C without damping;
// LIGGGHTS 3.8.0 `rolling_friction epsd2`):
//     k_r = k_t R*^2                         (k_t: current Hertz-Mindlin tangential stiffness)
//     omega_t = omega_rel - (omega_rel . n) n
//     M_r += k_r omega_t dt                  (history, like xi)
//     if |M_r| > mu_r R* |F_n|: M_r scaled back to that magnitude
//     torque -M_r on i, +M_r on j
// F_n is the same normal force as in the Coulomb limit (Hertz + damping, cohesion not subtracted,
// unless tangential_reduce).
#pragma once
#include "core/hd.hpp"
#include <cmath>

#include "core/vec3.hpp"

namespace biodem::contact {

/// Updates `m_r` in place and returns the rolling torque on i.
BIODEM_HD inline Vec3 epsd2_rolling_torque(Vec3& m_r, const Vec3& w_rel, const Vec3& n, double k_t, double r_eff_m,
                                 double rolling_friction, double normal_force_abs, double dt) {
  const Vec3 w_t = w_rel - dot(w_rel, n) * n;
  m_r += (k_t * r_eff_m * r_eff_m * dt) * w_t;
  const double limit = rolling_friction * r_eff_m * normal_force_abs;
  const double mag2 = norm2(m_r);
  if (mag2 > limit * limit) m_r *= limit / std::sqrt(mag2);
  return -m_r;
}

}  // namespace biodem::contact
