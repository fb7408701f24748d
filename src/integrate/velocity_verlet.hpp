// The per-body parts of the velocity-Verlet step (src/sim/simulation.hpp), shared by the CPU
// engine and the GPU kernels. A single sphere with equal principal moments integrates its
// angular velocity directly; any other body (a clump) integrates its lab angular momentum and
// turns by the free-rotor splitting of rigid_rotation.hpp.
#pragma once
#include <cstdint>

#include "core/hd.hpp"
#include "core/quat.hpp"
#include "core/vec3.hpp"
#include "integrate/rigid_rotation.hpp"

namespace biodem::integrate {

BIODEM_HD inline bool spins_as_sphere(std::uint32_t sphere_count, const Vec3& inertia) {
  return sphere_count == 1 && inertia.x == inertia.y && inertia.y == inertia.z;
}

/// kick_and_drift without the free-rotor turn: the half kicks and the drift of the position, and
/// a single sphere's spin. Returns false for a body that must still turn by
/// free_rotation_step(q, l, inertia, dt) (the CPU engine turns several such bodies at once).
BIODEM_HD inline bool kick_and_drift_but_turn(Vec3& x, Vec3& v, Vec3& omega, Vec3& l, double mass, const Vec3& inertia,
                                              std::uint32_t sphere_count, const Vec3& force, const Vec3& torque,
                                              double h, double dt) {
  const double inv_m = 1.0 / mass;
  v += (h * inv_m) * force;
  x += dt * v;
  if (spins_as_sphere(sphere_count, inertia)) {
    omega += (h / inertia.x) * torque;
    return true;
  }
  l += h * torque;
  return false;
}

/// First half kick (dt/2 of force and torque) and drift over dt: position, and orientation with
/// the angular velocity it ends with.
BIODEM_HD inline void kick_and_drift(Vec3& x, Vec3& v, Vec3& omega, Vec3& l, Quat& q, double mass, const Vec3& inertia,
                                     std::uint32_t sphere_count, const Vec3& force, const Vec3& torque, double h,
                                     double dt) {
  if (!kick_and_drift_but_turn(x, v, omega, l, mass, inertia, sphere_count, force, torque, h, dt))
    omega = free_rotation_step(q, l, inertia, dt);
}

/// Second half kick (dt/2 of the new force and torque).
BIODEM_HD inline void half_kick(Vec3& v, Vec3& omega, Vec3& l, const Quat& q, double mass, const Vec3& inertia,
                                std::uint32_t sphere_count, const Vec3& force, const Vec3& torque, double h) {
  v += (h / mass) * force;
  if (spins_as_sphere(sphere_count, inertia)) {
    omega += (h / inertia.x) * torque;
  } else {
    l += h * torque;
    omega = angular_velocity_from_momentum(q, l, inertia);
  }
}

/// half_kick of step c, then kick_and_drift of step c + 1 with the same force and torque (the GPU
/// engine's fused body kernels): the same operations on the same values, so the same bits, less
/// the lab angular velocity that half_kick derives for a clump from its angular momentum (two
/// rotations and three divisions), which the turn of kick_and_drift replaces unread.
BIODEM_HD inline void half_kick_then_kick_and_drift(Vec3& x, Vec3& v, Vec3& omega, Vec3& l, Quat& q, double mass,
                                                    const Vec3& inertia, std::uint32_t sphere_count, const Vec3& force,
                                                    const Vec3& torque, double h, double dt) {
  if (spins_as_sphere(sphere_count, inertia)) {
    half_kick(v, omega, l, q, mass, inertia, sphere_count, force, torque, h);
  } else {
    v += (h / mass) * force;
    l += h * torque;
  }
  kick_and_drift(x, v, omega, l, q, mass, inertia, sphere_count, force, torque, h, dt);
}

}  // namespace biodem::integrate
