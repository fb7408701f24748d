// Hertz elastic normal force (SPEC 2.2; Hertz 1882; Johnson, Contact Mechanics, 1985, ch. 4;
// LIGGGHTS 3.8.0 `model hertz`):
//     k_n = (4/3) Y* sqrt(R* delta),   F_n,el = k_n delta = (4/3) Y* sqrt(R*) delta^(3/2)
// Elastic energy stored in the contact: U = (8/15) Y* sqrt(R*) delta^(5/2).
#pragma once
#include "core/hd.hpp"
#include <cmath>

namespace biodem::contact {

// R: double, or SIMD lanes of doubles (core/lanes.hpp).
template <class R>
BIODEM_HD inline R hertz_normal_stiffness(R y_eff_pa, R r_eff_m, R overlap_m) {
  using std::sqrt;
  return 4.0 / 3.0 * y_eff_pa * sqrt(r_eff_m * overlap_m);
}
template <class R>
BIODEM_HD inline R hertz_elastic_force(R y_eff_pa, R r_eff_m, R overlap_m) {
  return hertz_normal_stiffness(y_eff_pa, r_eff_m, overlap_m) * overlap_m;
}
BIODEM_HD inline double hertz_elastic_energy(double y_eff_pa, double r_eff_m, double overlap_m) {
  return 8.0 / 15.0 * y_eff_pa * std::sqrt(r_eff_m) * std::pow(overlap_m, 2.5);
}

}  // namespace biodem::contact
