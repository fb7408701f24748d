// The flowability analysis of one drum time series (SPEC 6): which samples are analysed, the
// drum speed, the events and the distributions of UAS, avalanche size, f and r^2. Pure
// computation on a Series (no files): `biodem analyze` and `biodem compare` share it.
#pragma once
#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "analysis/distributions.hpp"
#include "analysis/events.hpp"
#include "analysis/series.hpp"

namespace biodem::analysis {

struct FlowabilityOptions {
  EventParams events;
  std::optional<double> rpm;       // drum speed; default: from the revolution column
  std::optional<double> skip_s;    // drop the first T seconds of the analysed part
  std::optional<double> skip_rev;  // drop the first R revolutions of the analysed part
};

inline constexpr std::size_t kMinSamples = 3;
/// Fewer analysed samples than this: a warning that the series is too short to be read.
inline constexpr std::size_t kFewSamples = 50;

struct FlowabilityResult {
  double rpm = 0.0;
  bool rpm_from_series = false;
  std::size_t first_sample = 0;   // index of the first analysed sample in the series
  std::size_t samples_used = 0;   // from first_sample to the end
  EventDetection detection;
  // Raw values and their distributions, in descriptor_table() order:
  // uas_deg, drop_deg, f_percent, surface_r2.
  std::array<std::vector<double>, 4> values;
  std::array<Distribution, 4> distributions;
  std::vector<std::string> warnings;
  // The series' alpha made continuous (unwrap_alpha), as the events were found on it: what the
  // plots draw. `alpha_wraps`: how many times it went past the top of the drum.
  std::vector<double> alpha_deg;
  std::size_t alpha_wraps = 0;
};

/// alpha = 90 deg + atan2(x_c, -y_c) lies in (-90, 270] deg (SPEC 6): a bed carried over the top
/// of the drum (its centroid above the axis) wraps from 270 to -90 deg, which the event rule would
/// read as a 360 deg avalanche. Makes alpha continuous: where it jumps by more than 180 deg from
/// one sample to the next (an avalanche does not move the centroid half round the drum between
/// two samples), it and all later samples are shifted by -+360 deg. Returns the number of wraps.
/// analyze_flowability makes the analysed samples continuous and finds the events on them: a UAS
/// after the bed went over the top counts on past 270 deg (it is not folded back, where it would
/// read as a free-flowing bed), and the series is warned about.
std::size_t unwrap_alpha(std::vector<double>& alpha_deg);

/// Drum speed from the slope of the revolution column (revolution = rpm t / 60 while the drum
/// turns): the median m of (delta revolution / delta t) over the steps where the revolution
/// increases, then 60 x the slope over the longest stretch of steps each within 1e-6 of m (free of
/// the written columns' rounding). Throws biodem::Error when the column is missing or never
/// increases.
double rpm_from_revolution(const Series& s);

/// Throws biodem::Error on too few samples or an undeterminable speed.
FlowabilityResult analyze_flowability(const Series& s, const FlowabilityOptions& opt);

/// How the events depend on the event rule: one row per (rebound fraction, threshold).
struct SweepRow {
  double rebound_fraction;
  double threshold_deg;
  std::size_t events;
  double uas_p50, drop_p50, f_p50;  // medians (NaN when empty)
};

/// Thresholds of the sweep (deg): the range issue 12 asked for, 0.05 ... 2.
inline constexpr std::array<double, 7> kSweepThresholdsDeg{0.05, 0.1, 0.25, 0.5, 1.0, 1.5, 2.0};

/// Rebound fractions of the sweep: none, the default, and values either side of it.
inline std::vector<double> sweep_rebound_fractions() {
  return {0.0, 0.1, kDefaultReboundFraction, 0.25, 0.5};
}

/// Runs analyze_flowability for every (rho, h) pair, with the other options of `opt`.
std::vector<SweepRow> sweep_event_rule(const Series& s, const FlowabilityOptions& opt,
                                       const std::vector<double>& thresholds_deg,
                                       const std::vector<double>& rebound_fractions);

}  // namespace biodem::analysis
