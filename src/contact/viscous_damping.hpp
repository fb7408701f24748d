// Viscous damping of the Hertz-Mindlin model, set from the coefficient of restitution
// (SPEC 2.2; Tsuji, Tanaka & Ishida, Powder Technol. 71 (1992) 239; the form used by
// LIGGGHTS 3.8.0 `model hertz` / `tangential history`):
//     beta  = ln(e) / sqrt(ln^2(e) + pi^2)                (<= 0)
//     S_n   = 2 Y* sqrt(R* delta),   S_t = 8 G* sqrt(R* delta)
//     gamma = -2 sqrt(5/6) beta sqrt(S m*)                 (>= 0)
// The damping force is -gamma v (opposes the relative velocity). It is NOT clamped: the damped
// normal force may become slightly tensile at the end of a contact, which is what makes the
// measured restitution equal the input e (SPEC 2.4).
#pragma once
#include "core/hd.hpp"
#include <cmath>
#include <numbers>

namespace biodem::contact {

BIODEM_HD inline double damping_beta(double restitution) {
  const double l = std::log(restitution);
  return l / std::sqrt(l * l + std::numbers::pi * std::numbers::pi);
}
/// gamma for a stiffness-like modulus S (S_n or S_t) and effective mass m*. R: double, or SIMD
/// lanes of doubles (core/lanes.hpp).
template <class R>
BIODEM_HD inline R damping_coefficient(R beta, R s_modulus, R m_eff_kg) {
  using std::sqrt;
  return -2.0 * std::sqrt(5.0 / 6.0) * beta * sqrt(s_modulus * m_eff_kg);
}
template <class R>
BIODEM_HD inline R normal_damping_coefficient(R beta, R y_eff_pa, R r_eff_m, R overlap_m, R m_eff_kg) {
  using std::sqrt;
  return damping_coefficient(beta, R(2.0 * y_eff_pa * sqrt(r_eff_m * overlap_m)), m_eff_kg);
}
template <class R>
BIODEM_HD inline R tangential_damping_coefficient(R beta, R g_eff_pa, R r_eff_m, R overlap_m, R m_eff_kg) {
  using std::sqrt;
  return damping_coefficient(beta, R(8.0 * g_eff_pa * sqrt(r_eff_m * overlap_m)), m_eff_kg);
}

}  // namespace biodem::contact
