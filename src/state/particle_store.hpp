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

}  // namespace biodem::state
