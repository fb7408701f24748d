// Structure-of-arrays particle state with stable indices (STYLE.md 1).
//
// Bodies carry the dynamics (a sphere is a one-sphere body); spheres carry the contact geometry.
// Each body owns a contiguous range of spheres. After every position update the sphere arrays
// are refreshed from their bodies; contact forces accumulate per sphere and are then reduced into
// body force and torque about the body's centre of mass.
#pragma once
#include <cstdint>
#include <vector>

#include "core/quat.hpp"
#include "core/vec3.hpp"

namespace biodem::state {

struct SphereStore {
  std::vector<Vec3> position_m;
  std::vector<Vec3> velocity_m_s;       // of the sphere centre (body velocity + omega x offset)
  std::vector<Vec3> angular_velocity_rad_s;  // = the body's
  std::vector<double> radius_m;
  std::vector<Vec3> offset_body_m;      // centre in the body frame
  std::vector<std::uint32_t> body;
  std::vector<std::uint16_t> material;
  std::vector<double> body_mass_kg;     // mass of the owning body (m* uses body masses, SPEC 2.1)
  std::vector<Vec3> force_n;            // contact force on the sphere (this step)
  std::vector<Vec3> torque_n_m;         // contact torque about the sphere centre (this step)

  std::size_t size() const { return radius_m.size(); }
};

struct BodyStore {
  std::vector<Vec3> position_m;         // centre of mass
  std::vector<Vec3> velocity_m_s;
  std::vector<Vec3> angular_velocity_rad_s;  // lab frame
  std::vector<Vec3> angular_momentum_kg_m2_s;  // lab frame; integrated for clumps only (spheres use omega directly)
  std::vector<Quat> orientation;        // body -> lab
  std::vector<double> mass_kg;
  std::vector<Vec3> inertia_kg_m2;      // principal moments (body frame)
  std::vector<std::uint32_t> shape;     // template index
  std::vector<std::uint32_t> id;        // stable id (insertion order); storage order changes with spatial sorting
  std::vector<std::uint32_t> first_sphere;
  std::vector<std::uint32_t> sphere_count;
  std::vector<Vec3> force_n;            // total force incl. gravity
  std::vector<Vec3> torque_n_m;         // about the centre of mass, lab frame

  std::size_t size() const { return mass_kg.size(); }
};

/// The bodies old_of_new[0], old_of_new[1], ... of `b`, in that order (a permutation or a
/// subset): every per-body field except first_sphere, which the caller renumbers.
inline BodyStore gather(const BodyStore& b, const std::vector<std::uint32_t>& old_of_new) {
  BodyStore out;
  auto take = [&](auto& dst, const auto& src) {
    dst.resize(old_of_new.size());
    for (std::size_t q = 0; q < old_of_new.size(); ++q) dst[q] = src[old_of_new[q]];
  };
  take(out.position_m, b.position_m);
  take(out.velocity_m_s, b.velocity_m_s);
  take(out.angular_velocity_rad_s, b.angular_velocity_rad_s);
  take(out.angular_momentum_kg_m2_s, b.angular_momentum_kg_m2_s);
  take(out.orientation, b.orientation);
  take(out.mass_kg, b.mass_kg);
  take(out.inertia_kg_m2, b.inertia_kg_m2);
  take(out.shape, b.shape);
  take(out.id, b.id);
  take(out.sphere_count, b.sphere_count);
  take(out.force_n, b.force_n);
  take(out.torque_n_m, b.torque_n_m);
  out.first_sphere.resize(old_of_new.size());
  return out;
}

/// The spheres old_of_new[0], ... of `s`: every per-sphere field except body, which the caller
/// renumbers.
inline SphereStore gather(const SphereStore& s, const std::vector<std::uint32_t>& old_of_new) {
  SphereStore out;
  auto take = [&](auto& dst, const auto& src) {
    dst.resize(old_of_new.size());
    for (std::size_t q = 0; q < old_of_new.size(); ++q) dst[q] = src[old_of_new[q]];
  };
  take(out.position_m, s.position_m);
  take(out.velocity_m_s, s.velocity_m_s);
  take(out.angular_velocity_rad_s, s.angular_velocity_rad_s);
  take(out.radius_m, s.radius_m);
  take(out.offset_body_m, s.offset_body_m);
  take(out.material, s.material);
  take(out.body_mass_kg, s.body_mass_kg);
  take(out.force_n, s.force_n);
  take(out.torque_n_m, s.torque_n_m);
  out.body.resize(old_of_new.size());
  return out;
}

}  // namespace biodem::state
