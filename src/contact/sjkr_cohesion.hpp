// Simplified JKR cohesion (SPEC 2.4; LIGGGHTS 3.8.0 `cohesion sjkr`): an attractive normal
// force proportional to the contact area, only while the bodies overlap:
//     F_coh = CED * A
//   sphere-sphere (centre distance d; the circle where the spheres intersect):
//     A = pi (R_i + R_j - d)(d + R_i - R_j)(d - R_i + R_j)(d + R_i + R_j) / (4 d^2)
//     (Pachon-Morales et al. 2020 print Eq. 5 without the minus sign that makes A positive)
//   sphere-wall (distance d from centre to wall):  A = pi (R_i^2 - d^2)
// It is subtracted from the scalar normal force (the force vector F_n n); the friction and rolling
// limits keep the force without it (SPEC 2.2: LIGGGHTS 3.8.0 `tangential_reduce off`), unless the
// case sets [contact] tangential_reduce = true.
#pragma once
#include "core/hd.hpp"
#include <numbers>

namespace biodem::contact {

// R: double, or SIMD lanes of doubles (core/lanes.hpp).
template <class R>
BIODEM_HD inline R sjkr_area_sphere_sphere(R r_i, R r_j, R d) {
  return std::numbers::pi * (r_i + r_j - d) * (d + r_i - r_j) * (d - r_i + r_j) * (d + r_i + r_j) / (4.0 * d * d);
}
template <class R>
BIODEM_HD inline R sjkr_area_sphere_wall(R r_i, R d) {
  return std::numbers::pi * (r_i * r_i - d * d);
}
/// Magnitude of the attractive force (to be subtracted from the repulsive normal force).
template <class R>
BIODEM_HD inline R sjkr_force(R cohesion_energy_density_j_m3, R area_m2) {
  return cohesion_energy_density_j_m3 * area_m2;
}

}  // namespace biodem::contact
