// A particle shape as a rigid template of spheres (SPEC 3): spheres are the one-sphere case.
// Offsets are in the body frame: centre of mass at the origin, axes along the principal axes of
// inertia, so the body's inertia tensor is diagonal in its own frame.
#pragma once
#include <string>
#include <vector>

#include "config/case_config.hpp"
#include "core/quat.hpp"
#include "core/vec3.hpp"

namespace biodem::shapes {

struct ClumpTemplate {
  std::string name;
  std::vector<Vec3> offsets_m;  // body frame
  std::vector<double> radii_m;
  double volume_m3 = 0.0;                 // of the union of the spheres (overlaps counted once)
  Vec3 principal_inertia_per_density_m5;  // I / rho about the principal axes
  // Rotation from the frame the shape was given in to the principal frame used for offsets_m:
  // offsets_m = rotate_inverse(given_to_principal, given_offsets - com).
  Quat principal_frame;
  double bounding_radius_m = 0.0;  // max |offset| + r
  double min_radius_m = 0.0;
  double max_radius_m = 0.0;
  std::size_t sphere_count() const { return radii_m.size(); }
  double equivalent_diameter_m() const;  // (6 V / pi)^(1/3)
};

/// Needle geometry of SPEC 3, eqs. 7-9 (unscaled inputs, lengths in m).
struct NeedleGeometry {
  int n_spheres = 1;
  double sphere_diameter_m = 0.0;
  double length_m = 0.0;
  double volume_m3 = 0.0;
  double equivalent_diameter_m = 0.0;
};
NeedleGeometry needle_geometry(double d_m, double aspect_ratio, double overlap_factor);

/// Builds the template of a shape, all lengths multiplied by `coarse_grain`.
/// Throws biodem::Error for shapes that cannot be built (names the shape).
ClumpTemplate make_template(const config::Shape& shape, double coarse_grain);

}  // namespace biodem::shapes

namespace biodem::shapes {
/// Orientation of a body (principal frame -> lab) for a particle whose orientation is given
/// relative to the frame its shape was written in: identity shows the shape as written.
inline Quat body_orientation(const ClumpTemplate& t, const Quat& given) { return normalized(given * t.principal_frame); }
}  // namespace biodem::shapes
