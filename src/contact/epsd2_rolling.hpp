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

#include "core/lanes.hpp"

namespace biodem::contact {

/// Updates `m_r` in place and returns the rolling torque on i. R: double (vectors Vec3), or SIMD
/// lanes of doubles (core/lanes.hpp; the cap is then a blend).
template <class R>
BIODEM_HD inline vec3_t<R> epsd2_rolling_torque(vec3_t<R>& m_r, const vec3_t<R>& w_rel, const vec3_t<R>& n, R k_t,
                                                R r_eff_m, R rolling_friction, R normal_force_abs, double dt) {
  const vec3_t<R> w_t = w_rel - dot(w_rel, n) * n;
  m_r += (k_t * r_eff_m * r_eff_m * dt) * w_t;
  const R limit = rolling_friction * r_eff_m * normal_force_abs;
  const R mag2 = norm2(m_r);
  if constexpr (std::is_same_v<R, double>) {
    if (mag2 > limit * limit) m_r *= limit / std::sqrt(mag2);
  } else {
    using std::sqrt;
    m_r = lane_select(mag2 > limit * limit, m_r * (limit / sqrt(mag2)), m_r);
  }
  return -m_r;
}

}  // namespace biodem::contact
