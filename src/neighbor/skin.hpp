// The default Verlet-list skin ([run].skin_m unset), in one place for the case report, the case
// checks and both engines.
#pragma once

namespace biodem::neighbor {

/// Default skin as a fraction of the smallest sphere radius in use: 0.25, an eighth of the
/// smallest diameter (d/8). With the SIMD pair pass and the faster list build, a shorter list
/// pays for the extra rebuilds: against d/4, the whole small glass drum (insertion, 10,000 settle
/// and 20,000 rotation steps) took 5-6 % less time on one thread and 11 % less on two, and the
/// coarse-grained needle drum 5-14 % less (docs/performance.md). Before: d/4.
inline constexpr double kDefaultSkinPerMinRadius = 0.25;

/// The default skin for a smallest sphere radius.
constexpr double default_skin_m(double min_radius_m) { return kDefaultSkinPerMinRadius * min_radius_m; }

}  // namespace biodem::neighbor
