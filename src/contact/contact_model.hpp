// Composition of the contact sub-models in fixed slots (SPEC 2.2 order of evaluation):
//   geometry -> Hertz normal + viscous damping -> SJKR cohesion -> Mindlin tangential with
//   Coulomb limit -> EPSD2 rolling.
// The Coulomb and rolling limits take |F_n| of Hertz + damping, cohesion NOT subtracted: LIGGGHTS
// 3.8.0 `cohesion sjkr` adds its force to sidata.Fn (which the tangential and rolling models read)
// only with `tangential_reduce on`, off by default (cohesion_model_sjkr.h, registerSettings and
// surfacesIntersect). The reduced rule (limits from Hertz + damping - cohesion) is the per-pair flag
// PairParams::tangential_reduce ([contact] tangential_reduce = true).
// Cohesion and rolling are compile-time slots: the driver picks the instantiation once at
// set-up from the pair table (no per-contact dispatch). Pure function: geometry, parameters and
// the contact's own history in; forces and torques out.
#pragma once
#include "core/hd.hpp"
#include "contact/contact_geometry.hpp"
#include "contact/epsd2_rolling.hpp"
#include "contact/hertz_normal.hpp"
#include "contact/mindlin_tangential.hpp"
#include "contact/pair_table.hpp"
#include "contact/sjkr_cohesion.hpp"
#include "contact/viscous_damping.hpp"

namespace biodem::contact {

/// Per-contact history (tangential spring and rolling spring), zero at first touch.
template <class R>
struct ContactHistoryT {
  vec3_t<R> xi{};   // accumulated tangential displacement, m
  vec3_t<R> m_r{};  // EPSD2 rolling torque, N m
};
using ContactHistory = ContactHistoryT<double>;

template <class R>
struct ContactOutputT {
  vec3_t<R> force_i{};   // on i; -force_i acts on j
  vec3_t<R> torque_i{};  // about i's sphere centre
  vec3_t<R> torque_j{};  // about j's sphere centre (unused for walls)
  R normal_force_n = 0.0;  // scalar normal force after damping and cohesion
  R limit_force_n = 0.0;   // the scalar normal force whose magnitude bounds friction and rolling
};
using ContactOutput = ContactOutputT<double>;

/// The pair parameters of each lane's contact, for SIMD lanes (the scalar laws take PairParams).
/// tangential_reduce is one setting for the whole case ([contact]), so it is not a lane value.
template <class R>
struct PairParamsT {
  R y_eff_pa = 0.0, g_eff_pa = 0.0, beta = 0.0, friction = 0.0, rolling_friction = 0.0,
    cohesion_energy_density_j_m3 = 0.0;
  bool tangential_reduce = false;
};
template <class R> struct PairParamsOf { using type = PairParamsT<R>; };
template <> struct PairParamsOf<double> { using type = PairParams; };

/// R: double (one contact; the GPU kernels, walls, tests), or SIMD lanes of doubles (one contact
/// per lane, the CPU pair pass: src/sim/pair_pass_lanes.hpp). Each lane computes what the scalar
/// call computes, in the same order (core/lanes.hpp).
template <bool Cohesion, bool Rolling, class R>
BIODEM_HD inline ContactOutputT<R> evaluate_contact(const ContactGeometryT<R>& g,
                                                    const typename PairParamsOf<R>::type& p, ContactHistoryT<R>& h,
                                                    R cohesion_area_m2, double dt) {
  const vec3_t<R>& n = g.normal;
  const R v_n = dot(g.v_rel, n);
  R f_n = hertz_elastic_force(p.y_eff_pa, g.r_eff_m, g.overlap_m) -
          normal_damping_coefficient(p.beta, p.y_eff_pa, g.r_eff_m, g.overlap_m, g.m_eff_kg) * v_n;
  R f_limit = f_n;
  if constexpr (Cohesion) {
    f_n -= sjkr_force(p.cohesion_energy_density_j_m3, cohesion_area_m2);
    if (p.tangential_reduce) f_limit = f_n;
  }
  const R abs_f_n = lane_abs(f_limit);

  const vec3_t<R> v_t = g.v_rel - v_n * n;
  const R k_t = mindlin_tangential_stiffness(p.g_eff_pa, g.r_eff_m, g.overlap_m);
  const R gamma_t = tangential_damping_coefficient(p.beta, p.g_eff_pa, g.r_eff_m, g.overlap_m, g.m_eff_kg);
  const vec3_t<R> t_force = mindlin_tangential_force(h.xi, v_t, n, k_t, gamma_t, p.friction, abs_f_n, dt).force;

  ContactOutputT<R> out;
  out.normal_force_n = f_n;
  out.limit_force_n = f_limit;
  out.force_i = f_n * n + t_force;
  out.torque_i = cross(g.lever_i, t_force);
  out.torque_j = cross(g.lever_j, -t_force);
  if constexpr (Rolling) {
    const vec3_t<R> m = epsd2_rolling_torque(h.m_r, g.w_rel, n, k_t, g.r_eff_m, p.rolling_friction, abs_f_n, dt);
    out.torque_i += m;
    out.torque_j -= m;
  }
  return out;
}

}  // namespace biodem::contact
