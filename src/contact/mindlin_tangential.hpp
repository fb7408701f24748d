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

#include "core/lanes.hpp"

namespace biodem::contact {

// R: double (vectors Vec3), or SIMD lanes of doubles (core/lanes.hpp; the cap is then a blend).
template <class R>
BIODEM_HD inline R mindlin_tangential_stiffness(R g_eff_pa, R r_eff_m, R overlap_m) {
  using std::sqrt;
  return 8.0 * g_eff_pa * sqrt(r_eff_m * overlap_m);
}

template <class R>
struct TangentialResultT {
  vec3_t<R> force{};                  // on body i
  decltype(R{} > R{}) sliding{};      // bool, or a lane mask
};
using TangentialResult = TangentialResultT<double>;

/// Updates the history `xi` in place and returns the tangential force on i.
template <class R>
BIODEM_HD inline TangentialResultT<R> mindlin_tangential_force(vec3_t<R>& xi, const vec3_t<R>& v_t, const vec3_t<R>& n, R k_t,
                                                    R gamma_t, R friction, R normal_force_abs, double dt) {
  xi += v_t * dt;
  xi -= dot(xi, n) * n;
  const vec3_t<R> spring = -k_t * xi;
  const R limit = friction * normal_force_abs;
  const R spring2 = norm2(spring);
  TangentialResultT<R> r;
  r.sliding = spring2 > limit * limit;
  if constexpr (std::is_same_v<R, double>) {
    if (r.sliding) {
      r.force = spring * (limit / std::sqrt(spring2));
      xi = r.force * (-1.0 / k_t);
    } else {
      r.force = spring - gamma_t * v_t;
    }
  } else {
    using std::sqrt;
    const vec3_t<R> slide = spring * (limit / sqrt(spring2));
    xi = lane_select(r.sliding, slide * (-1.0 / k_t), xi);
    r.force = lane_select(r.sliding, slide, spring - gamma_t * v_t);
  }
  return r;
}

}  // namespace biodem::contact
