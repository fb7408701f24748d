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
#include "core/small_angle.hpp"
#include "core/vec3.hpp"

namespace biodem::integrate {

/// Advances the orientations q[n] (body -> lab) of N bodies by `h` for lab angular momenta l[n]
/// and principal moments inertia[n], and writes their new lab angular velocities to omega[n].
/// The bodies go in lockstep: each line below is done for every body before the next, with the
/// same operations for each body as for N = 1 (so the same bits for any N), and the N
/// independent chains of dependent sub-steps overlap in the CPU (one body's chain is latency-
/// bound: about 100 ns on the development VM).
template <int N>
BIODEM_HD inline void free_rotation_steps(Quat* q, const Vec3* l, const Vec3* inertia, double h, Vec3* omega) {
  Vec3 pi[N], inv_i[N];
  for (int n = 0; n < N; ++n) {
    pi[n] = rotate_inverse(q[n], l[n]);
    // The reciprocals do not depend on pi: off the chain of dependent sub-steps.
    inv_i[n] = Vec3{1.0 / inertia[n].x, 1.0 / inertia[n].y, 1.0 / inertia[n].z};
  }
  auto sub = [&](int k, double hk) {
    const int a = (k + 1) % 3, b = (k + 2) % 3;
    for (int n = 0; n < N; ++n) {
      // One sine and one cosine, of theta/2 (the quaternion's angle); those of theta follow by
      // the double-angle identities.
      const double half = 0.5 * hk * pi[n][k] * inv_i[n][k];
      double c2, s2;
      sincos_small_angle(half, s2, c2);
      const double c = c2 * c2 - s2 * s2, s = 2.0 * s2 * c2;
      // pi <- Rot(e_k, -theta) pi
      const double pa = pi[n][a], pb = pi[n][b];
      pi[n][a] = c * pa + s * pb;
      pi[n][b] = -s * pa + c * pb;
      // q <- q * (cos theta/2, sin theta/2 e_k), written out:
      //   w' = c2 w - s2 v_k,  v' = c2 v + s2 (w e_k + v x e_k)
      double v[3] = {q[n].x, q[n].y, q[n].z};
      const double w = q[n].w, vk = v[k], va = v[a], vb = v[b];
      q[n].w = c2 * w - s2 * vk;
      v[k] = c2 * vk + s2 * w;
      v[a] = c2 * va + s2 * vb;
      v[b] = c2 * vb - s2 * va;
      q[n].x = v[0];
      q[n].y = v[1];
      q[n].z = v[2];
    }
  };
  sub(0, 0.5 * h);
  sub(1, 0.5 * h);
  sub(2, h);
  sub(1, 0.5 * h);
  sub(0, 0.5 * h);
  for (int n = 0; n < N; ++n) {
    q[n] = normalized(q[n]);
    omega[n] = rotate(q[n], Vec3{pi[n].x * inv_i[n].x, pi[n].y * inv_i[n].y, pi[n].z * inv_i[n].z});
  }
}

/// Advances orientation `q` (body -> lab) by `h` for lab angular momentum `l` and principal
/// moments `inertia`. Returns the new lab angular velocity.
BIODEM_HD inline Vec3 free_rotation_step(Quat& q, const Vec3& l, const Vec3& inertia, double h) {
  Vec3 omega;
  free_rotation_steps<1>(&q, &l, &inertia, h, &omega);
  return omega;
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
