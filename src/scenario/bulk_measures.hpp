// Responses of the bulk tests (SPEC 7, issue 9), measured on plain arrays of sphere centres and
// radii so that synthetic scenes of known answer can test them.
//
// Angle of repose: the heap stands on a horizontal plate (height 0) about a vertical axis. The
// surface profile is the highest sphere top (centre height + radius) in each radial bin of width
// one bin_m, over all azimuths. The heap base radius R is the outer edge of the outermost bin
// whose surface stands at least two bin widths (two particle sizes) above the plate, so that the
// one-particle skirt that rolls away does not count; the angle is atan(-slope) of a least-squares
// line through the bin surfaces (at the bin centres) between fit_from and fit_to fractions of R
// (defaults 0.2 and 0.8: the cap and the toe are rounded on every heap). Heap height: the highest
// sphere top.
//
// Bulk density: mass of the bodies whose centre lies inside the container (below the rim: the
// surplus above it is struck off), over the container volume; solid fraction = bulk density /
// particle density (mass-weighted over materials: the sum of body volumes over the volume).
#pragma once
#include <vector>

#include "core/vec3.hpp"

namespace biodem::scenario {

struct HeapResult {
  bool valid = false;        // false when no bin stands two particle sizes high (no heap)
  double angle_deg = 0.0;    // 0 when there is no heap
  double height_m = 0.0;
  double base_radius_m = 0.0;
  std::size_t bins_fitted = 0;
};

/// centres and radii of the spheres; the plate is the plane through `origin` normal to `up`
/// (unit), the heap axis the line through `origin` along `up`.
HeapResult measure_heap(const std::vector<Vec3>& centres, const std::vector<double>& radii, const Vec3& origin,
                        const Vec3& up, double bin_m, double fit_from = 0.2, double fit_to = 0.8);

}  // namespace biodem::scenario
