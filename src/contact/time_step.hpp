// Time-step scales for Hertzian contacts (SPEC 2.5).
//
// Rayleigh time (the time a Rayleigh surface wave needs to cross a sphere; Li, Xu & Thornton,
// Powder Technol. 160 (2005) 219; the LIGGGHTS/EDEM guideline):
//     T_R = pi R sqrt(rho / G) / (0.1631 nu + 0.8766),   G = Y / (2 (1 + nu))
// Hertz collision duration of an elastic head-on impact (Johnson, Contact Mechanics, 1985, ch. 11):
//     t_c = 2.868 (m*^2 / (R* Y*^2 v))^(1/5)
// with the effective quantities of SPEC 2.1 and v the relative approach speed.
#pragma once
#include <cmath>
#include <numbers>

namespace biodem::contact {

inline double shear_modulus_pa(double young_pa, double poisson) { return young_pa / (2.0 * (1.0 + poisson)); }

inline double rayleigh_time_s(double radius_m, double density_kg_m3, double young_pa, double poisson) {
  return std::numbers::pi * radius_m * std::sqrt(density_kg_m3 / shear_modulus_pa(young_pa, poisson)) /
         (0.1631 * poisson + 0.8766);
}

/// 1/Y* contribution of one body: (1 - nu^2) / Y.
inline double inverse_effective_young_term(double young_pa, double poisson) {
  return (1.0 - poisson * poisson) / young_pa;
}
/// 1/G* contribution of one body: 2 (2 - nu)(1 + nu) / Y.
inline double inverse_effective_shear_term(double young_pa, double poisson) {
  return 2.0 * (2.0 - poisson) * (1.0 + poisson) / young_pa;
}

/// Hertz contact duration for an elastic impact at relative speed v (m/s).
inline double hertz_contact_time_s(double m_eff_kg, double r_eff_m, double y_eff_pa, double v_m_s) {
  return 2.868 * std::pow(m_eff_kg * m_eff_kg / (r_eff_m * y_eff_pa * y_eff_pa * v_m_s), 0.2);
}

/// Peak force of an elastic Hertz impact: F_max = (4/3) Y* sqrt(R*) delta_max^(3/2),
/// delta_max = (15 m* v^2 / (16 Y* sqrt(R*)))^(2/5).
inline double hertz_max_overlap_m(double m_eff_kg, double r_eff_m, double y_eff_pa, double v_m_s) {
  return std::pow(15.0 * m_eff_kg * v_m_s * v_m_s / (16.0 * y_eff_pa * std::sqrt(r_eff_m)), 0.4);
}
inline double hertz_peak_force_n(double m_eff_kg, double r_eff_m, double y_eff_pa, double v_m_s) {
  const double d = hertz_max_overlap_m(m_eff_kg, r_eff_m, y_eff_pa, v_m_s);
  return 4.0 / 3.0 * y_eff_pa * std::sqrt(r_eff_m) * std::pow(d, 1.5);
}

}  // namespace biodem::contact
