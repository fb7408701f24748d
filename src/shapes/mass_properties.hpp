// Volume, centre and second moments of a union of spheres (per unit density).
//
// Exact when no point lies inside three spheres (every needle with overlap factor c <= 0.5):
// union = sum of spheres - sum of pairwise lenses, a lens being the two spherical caps cut by
// the plane of the intersection circle. Cap integrals (slices of radius^2 = r^2 - z^2):
//   V = pi (r^3 z - z^3/3) |_a^r,  int z dV = pi (r^2 z^2/2 - z^4/4) |_a^r,
//   int z^2 dV = pi (r^2 z^3/3 - z^5/5) |_a^r,  int x^2 dV = (pi/4) int (r^2 - z^2)^2 dz.
// Otherwise a converged midpoint-rule integration over a voxel grid is used (see `exact`).
#pragma once
#include <vector>

#include "core/mat3.hpp"
#include "core/vec3.hpp"

namespace biodem::shapes {

struct MassProperties {
  double volume_m3 = 0.0;
  Vec3 first_moment_m4;   // int r dV
  Mat3 second_moment_m5;  // int r r^T dV (about the origin of the input frame)
  bool exact = true;      // false: numerical integration
  Vec3 centroid_m() const { return first_moment_m4 / volume_m3; }
  /// Inertia tensor per unit density about the centroid.
  Mat3 inertia_about_centroid_m5() const;
};

MassProperties union_of_spheres(const std::vector<Vec3>& centers_m, const std::vector<double>& radii_m);
/// Grid integration (resolution = cells along the longest bounding-box edge); for tests and fallback.
MassProperties union_of_spheres_numerical(const std::vector<Vec3>& centers_m, const std::vector<double>& radii_m,
                                          int resolution);

}  // namespace biodem::shapes
