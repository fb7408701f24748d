// Responses of the bulk tests (SPEC 7, issues 9 and 20), measured on plain arrays of sphere
// centres and radii so that synthetic scenes of known answer can test them.
//
// Angle of repose (docs/calibration.md, "Measuring the heap"): the heap stands on a horizontal
// plate (height 0) about a vertical axis.
//  1. The heap is one body of touching particles: bodies are joined when two of their spheres
//     overlap or nearly touch (gap below contact_gap_fraction x the smaller radius); the heap is
//     the largest such cluster among those that touch the plate. Every other body (a needle held
//     to the lifted cylinder, a cluster that rolled off, a body in flight) is a stray: it sets
//     neither the height nor the base radius nor the surface, and is counted.
//  2. Heap height H: the highest sphere top of the heap. Base radius R: the outer edge of the
//     outermost radial bin (width bin_m, all azimuths) where the heap stands at least two bin
//     widths (two particle sizes) high, so the one-particle skirt does not count.
//  3. The surface profile is taken in `sectors` vertical half-planes through the axis (azimuthal
//     sectors of equal angle): in each, the highest sphere top per radial bin. A straight line is
//     fitted (least squares, surface height against bin centre) to the bins whose surface lies
//     between fit_from and fit_to of H (defaults 0.2 and 0.8: the rounded cap and toe are left
//     out); the sector's angle is atan(-slope). The response is the mean over the sectors with at
//     least three such bins, and their sample standard deviation is the spread. A mean that is
//     not positive (the surface does not fall away from the axis) is no heap.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/vec3.hpp"

namespace biodem::scenario {

struct HeapOptions {
  double bin_m = 0.0;         // radial bin width (the particle size)
  std::size_t sectors = 8;    // vertical half-planes (SPEC 7: 4 to 8)
  double fit_from = 0.2;      // fraction of the heap height where the fitted band starts
  double fit_to = 0.8;        // ... and ends
  double contact_gap_fraction = 0.1;  // spheres closer than this x the smaller radius touch
};

struct HeapResult {
  bool valid = false;             // false: no heap two particle sizes high, fewer than half
                                  // the sectors (and fewer than 2) could be fitted, or the mean
                                  // of the sector angles is not positive (no slope falling
                                  // away from the axis)
  double angle_deg = 0.0;         // mean over the fitted sectors; 0 when not valid
  double angle_spread_deg = 0.0;  // sample standard deviation over the fitted sectors (also
                                  // when not valid, with min and max, for diagnosis)
  double angle_min_deg = 0.0, angle_max_deg = 0.0;
  std::vector<double> sector_angle_deg;  // one per sector; NaN where it could not be fitted
  std::size_t sectors_fitted = 0;
  std::size_t sectors_steep = 0;  // fitted from the band's two crossings (fewer than 3 bins in it)
  double height_m = 0.0;
  double base_radius_m = 0.0;
  std::size_t heap_bodies = 0;
  std::size_t stray_bodies = 0;
  std::size_t lifted_bodies = 0;  // strays whose lowest point is more than bin_m above the heap's
                                  // top (all of it when there is no heap): held up by the rig
};

/// centres, radii and the body of each sphere (any ids; spheres of one body share it); the plate
/// is the plane through `origin` normal to `up` (unit), the heap axis the line through `origin`
/// along `up`.
HeapResult measure_heap(const std::vector<Vec3>& centres, const std::vector<double>& radii,
                        const std::vector<std::uint32_t>& body_of_sphere, const Vec3& origin, const Vec3& up,
                        const HeapOptions& options);

}  // namespace biodem::scenario
