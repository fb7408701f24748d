// Torque-free rotation of a rigid body over one step by the symplectic splitting of Dullweber,
// Leimkuhler & McLachlan (J. Chem. Phys. 107 (1997) 5840): the free-rotor Hamiltonian
// T = sum_k pi_k^2 / (2 I_k) is split into its three principal terms, each an exact rotation
// about one body axis, composed symmetrically R1(h/2) R2(h/2) R3(h) R2(h/2) R1(h/2).
// Each sub-step rotates the body about body axis e_k by theta = h pi_k / I_k and the body-frame
// angular momentum pi by -theta, so the lab angular momentum is conserved to round-off and the
// energy error stays bounded (second order, time reversible).
#pragma once
#include "core/hd.hpp"
#include <cmath>

#include "core/quat.hpp"
#include "core/vec3.hpp"

namespace biodem::integrate {

/// Advances orientation `q` (body -> lab) by `h` for lab angular momentum `l` and principal
/// moments `inertia`. Returns the new lab angular velocity.
BIODEM_HD inline Vec3 free_rotation_step(Quat& q, const Vec3& l, const Vec3& inertia, double h) {
  Vec3 pi = rotate_inverse(q, l);
  auto sub = [&](int k, double hk) {
    const double theta = hk * pi[k] / inertia[k];
    Vec3 axis;
    axis[k] = 1.0;
    const double c = std::cos(theta), s = std::sin(theta);
    const int a = (k + 1) % 3, b = (k + 2) % 3;
    // pi <- Rot(e_k, -theta) pi
    const double pa = pi[a], pb = pi[b];
    pi[a] = c * pa + s * pb;
    pi[b] = -s * pa + c * pb;
    q = q * axis_angle(axis, theta);
  };
  sub(0, 0.5 * h);
  sub(1, 0.5 * h);
  sub(2, h);
  sub(1, 0.5 * h);
  sub(0, 0.5 * h);
  q = normalized(q);
  return rotate(q, Vec3{pi.x / inertia.x, pi.y / inertia.y, pi.z / inertia.z});
}

/// Lab angular velocity from lab angular momentum.
BIODEM_HD inline Vec3 angular_velocity_from_momentum(const Quat& q, const Vec3& l, const Vec3& inertia) {
  const Vec3 pi = rotate_inverse(q, l);
  return rotate(q, Vec3{pi.x / inertia.x, pi.y / inertia.y, pi.z / inertia.z});
}
BIODEM_HD inline Vec3 angular_momentum_from_velocity(const Quat& q, const Vec3& w, const Vec3& inertia) {
  const Vec3 wb = rotate_inverse(q, w);
  return rotate(q, Vec3{wb.x * inertia.x, wb.y * inertia.y, wb.z * inertia.z});
}

}  // namespace biodem::integrate
