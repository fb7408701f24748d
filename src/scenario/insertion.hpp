// Random, non-overlapping insertion of bodies (SPEC 5): random positions inside a region and
// uniformly random orientations (Shoemake, Graphics Gems III, 1992), rejecting any trial that
// overlaps an existing sphere, another new one, or leaves the region. Deterministic for a seed.
#pragma once
#include <cstdint>
#include <random>
#include <vector>

#include "sim/simulation.hpp"

namespace biodem::scenario {

/// A cylinder region about z (the drum interior) from z_min to z_max; `periodic_z` lets
/// spheres cross the z limits (the periodic image is checked for overlaps).
struct CylinderRegion {
  double radius_m = 0.0;
  double z_min_m = 0.0, z_max_m = 0.0;
  bool periodic_z = false;
};

struct InsertionRequest {
  std::uint32_t shape = 0;
  std::uint16_t material = 0;
};

/// The list of bodies to insert: counts per population by volume fraction (largest remainder),
/// in a random order. `volumes_m3[k]` is the particle volume of population k.
std::vector<InsertionRequest> plan_population(std::uint64_t count, const std::vector<double>& volume_fractions,
                                              const std::vector<double>& volumes_m3,
                                              const std::vector<InsertionRequest>& populations, std::mt19937_64& rng);

/// Tries to place the requests from `next` on; returns the index one past the last placed
/// request. Requests are placed in order; the wave has max_attempts trials per request still to
/// place, shared by all of them (a request may use more than max_attempts), and stops when they
/// are spent. A request placed within max_attempts trials draws the same numbers as it would
/// with a per-request limit.
std::size_t insert_wave(sim::Simulation& sim, const CylinderRegion& region, const std::vector<InsertionRequest>& todo,
                        std::size_t next, std::uint64_t max_attempts, std::mt19937_64& rng);

/// A region of any scene (issue 9): an axis-aligned box, or a finite cylinder from `base_m`
/// along the unit `axis` over `height_m`. Every sphere of an inserted body lies inside it.
struct Region {
  enum class Kind { Box, Cylinder };
  Kind kind = Kind::Box;
  Vec3 min_m, max_m;             // box
  Vec3 base_m, axis{0, 1, 0};    // cylinder: centre of its base circle, unit axis
  double radius_m = 0.0, height_m = 0.0;
  double volume_m3() const;
  bool contains(const Vec3& c, double r) const;  // the whole sphere inside
};

/// As insert_wave for the drum, into any region (uniform positions in the region).
std::size_t insert_wave(sim::Simulation& sim, const Region& region, const std::vector<InsertionRequest>& todo,
                        std::size_t next, std::uint64_t max_attempts, std::mt19937_64& rng);

Quat random_orientation(std::mt19937_64& rng);

}  // namespace biodem::scenario
