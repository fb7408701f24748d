// Derived quantities of a validated case (SPEC 2.5, 3, 5, 11): the numbers the parser checks,
// the engine is built from (driver/build_simulation.cpp) and the report prints
// (output/case_report.hpp), all from this one place so that the check and the run can never
// disagree (particle count for a fill fraction, smallest Rayleigh time, default skin).
//
// Conventions shared with the engine:
// - [insertion].coarse_grain multiplies the lengths of EVERY particle, inserted or explicit
//   (1 without [insertion]); templates are shapes::make_template(shape, particle_coarse_grain()).
// - "Particle types" are the (material, shape) combinations used by [[population]] entries and
//   explicit [[particle]] entries.
#pragma once
#include <cstddef>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include "config/case_config.hpp"
#include "shapes/clump_template.hpp"

namespace biodem::case_file {

/// (material, shape) combinations in use ("particle types"), in order of first appearance.
std::vector<std::pair<std::size_t, std::size_t>> particle_types(const config::CaseConfig& c);

/// Templates of the shapes in use (shape index -> template after coarse graining), built anew
/// on each call.
std::map<std::size_t, shapes::ClumpTemplate> used_templates(const config::CaseConfig& c);

/// The length factor applied to every particle: [insertion].coarse_grain, or 1.
double particle_coarse_grain(const config::CaseConfig& c);

/// pi D^2 / 4 * W.
double drum_volume_m3(const config::Drum& d);

/// Number-weighted mean particle volume of the insertion populations: with volume fractions
/// phi_k and particle volumes V_k (after coarse graining) the number fractions are
/// proportional to phi_k / V_k, so the mean is 1 / sum_k(phi_k / V_k). 0 without populations.
double mean_population_particle_volume_m3(const config::CaseConfig& c);

/// Particles [insertion] creates: `count`, or for a fill fraction
/// round(fill_fraction * bulk_solid_fraction * V_drum / mean particle volume).
/// 0 without [insertion] (explicit [[particle]] entries are not included).
std::uint64_t implied_particle_count(const config::CaseConfig& c);

/// Smallest Rayleigh time (SPEC 2.5) over the particle types in use, each evaluated with the
/// smallest sphere radius of its shape after coarse graining. +infinity if there is none.
double smallest_rayleigh_time_s(const config::CaseConfig& c);

/// [run].skin_m, or its default (neighbor::default_skin_m of the smallest sphere radius in use;
/// 0 if none).
double resolved_skin_m(const config::CaseConfig& c);

/// The top of the speed images' colour scale (output/speed_image.hpp): [output].speed_image_max_m_s,
/// or the larger of twice the drum's rim speed (2 |rpm| 2 pi / 60 R) and sqrt(|g| d), d the largest
/// volume-equivalent diameter of the shapes in use after coarse graining (the speed of a particle
/// that fell its own size: the order of a cascade's surface speed), so that the flowing layer
/// spans the colours and the bed turning with the drum the lowest of them; 0.1 m/s where both
/// are 0. 0 without a [drum].
double speed_image_scale_m_s(const config::CaseConfig& c);

}  // namespace biodem::case_file
