// The default Verlet-list skin ([run].skin_m unset), in one place for the case report, the case
// checks and both engines.
#pragma once

namespace biodem::neighbor {

/// Default skin as a fraction of the smallest sphere radius in use: 0.5, a quarter of the
/// smallest diameter (d/4). Measured on the glass drum against d/2, it halves the list for
/// about twice as many rebuilds (docs/performance.md).
inline constexpr double kDefaultSkinPerMinRadius = 0.5;

/// The default skin for a smallest sphere radius.
constexpr double default_skin_m(double min_radius_m) { return kDefaultSkinPerMinRadius * min_radius_m; }

}  // namespace biodem::neighbor
