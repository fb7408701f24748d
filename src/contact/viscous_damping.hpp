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
/// gamma for a stiffness-like modulus S (S_n or S_t) and effective mass m*.
BIODEM_HD inline double damping_coefficient(double beta, double s_modulus, double m_eff_kg) {
  return -2.0 * std::sqrt(5.0 / 6.0) * beta * std::sqrt(s_modulus * m_eff_kg);
}
BIODEM_HD inline double normal_damping_coefficient(double beta, double y_eff_pa, double r_eff_m, double overlap_m,
                                         double m_eff_kg) {
  return damping_coefficient(beta, 2.0 * y_eff_pa * std::sqrt(r_eff_m * overlap_m), m_eff_kg);
}
BIODEM_HD inline double tangential_damping_coefficient(double beta, double g_eff_pa, double r_eff_m, double overlap_m,
                                             double m_eff_kg) {
  return damping_coefficient(beta, 8.0 * g_eff_pa * std::sqrt(r_eff_m * overlap_m), m_eff_kg);
}

}  // namespace biodem::contact
