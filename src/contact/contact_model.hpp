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
struct ContactHistory {
  Vec3 xi;   // accumulated tangential displacement, m
  Vec3 m_r;  // EPSD2 rolling torque, N m
};

struct ContactOutput {
  Vec3 force_i;   // on i; -force_i acts on j
  Vec3 torque_i;  // about i's sphere centre
  Vec3 torque_j;  // about j's sphere centre (unused for walls)
  double normal_force_n = 0.0;  // scalar normal force after damping and cohesion
  double limit_force_n = 0.0;   // the scalar normal force whose magnitude bounds friction and rolling
};

template <bool Cohesion, bool Rolling>
BIODEM_HD inline ContactOutput evaluate_contact(const ContactGeometry& g, const PairParams& p, ContactHistory& h,
                                      double cohesion_area_m2, double dt) {
  const Vec3& n = g.normal;
  const double v_n = dot(g.v_rel, n);
  double f_n = hertz_elastic_force(p.y_eff_pa, g.r_eff_m, g.overlap_m) -
               normal_damping_coefficient(p.beta, p.y_eff_pa, g.r_eff_m, g.overlap_m, g.m_eff_kg) * v_n;
  double f_limit = f_n;
  if constexpr (Cohesion) {
    f_n -= sjkr_force(p.cohesion_energy_density_j_m3, cohesion_area_m2);
    if (p.tangential_reduce) f_limit = f_n;
  }
  const double abs_f_n = f_limit < 0.0 ? -f_limit : f_limit;

  const Vec3 v_t = g.v_rel - v_n * n;
  const double k_t = mindlin_tangential_stiffness(p.g_eff_pa, g.r_eff_m, g.overlap_m);
  const double gamma_t = tangential_damping_coefficient(p.beta, p.g_eff_pa, g.r_eff_m, g.overlap_m, g.m_eff_kg);
  const TangentialResult t = mindlin_tangential_force(h.xi, v_t, n, k_t, gamma_t, p.friction, abs_f_n, dt);

  ContactOutput out;
  out.normal_force_n = f_n;
  out.limit_force_n = f_limit;
  out.force_i = f_n * n + t.force;
  out.torque_i = cross(g.lever_i, t.force);
  out.torque_j = cross(g.lever_j, -t.force);
  if constexpr (Rolling) {
    const Vec3 m = epsd2_rolling_torque(h.m_r, g.w_rel, n, k_t, g.r_eff_m, p.rolling_friction, abs_f_n, dt);
    out.torque_i += m;
    out.torque_j -= m;
  }
  return out;
}

}  // namespace biodem::contact
