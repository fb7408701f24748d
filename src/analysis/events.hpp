// Avalanche events on a centroid-angle series alpha(t) (SPEC 6).
//
// An event starts at a local maximum of alpha and ends at the following local minimum; drops
// smaller than a threshold h are not events. Extrema are found with a hysteresis ("zig-zag",
// equivalently peak prominence >= h on the falling side) scan:
//   * a maximum is confirmed once alpha has fallen at least h below it, a minimum once alpha has
//     risen at least max(h, min(rho x (alpha at the event's start - the minimum), cap)) above it
//     (rho the rebound fraction, default 0.15, cap 1 deg: a rebound inside a collapsing
//     avalanche does not split it; chosen from simulated series, docs/analysis.md section 3.1);
//     confirmed maxima and minima alternate;
//   * an event is a confirmed maximum (start) and the lowest sample before the next confirmed
//     maximum (end), so wiggles smaller than h neither create events nor split one drop in two;
//   * the start is the last sample at the maximum, the end the first sample at the minimum;
//   * the first maximum counts only if alpha rose at least h up to it within the series
//     (otherwise the series began inside an avalanche and its UAS would be wrong);
//   * an avalanche still running at the end of the series ends at the last sample.
//
// Default threshold (when none is given): h = max(k * sigma, floor) with k = 8 and
// floor = 0.05 deg, where sigma is a robust estimate of the sample-to-sample noise of alpha:
//     sigma = 1.4826 * MAD(d2) / sqrt(6),   d2_i = alpha_{i+1} - 2 alpha_i + alpha_{i-1}.
// Second differences cancel the steady rise of alpha with the drum rotation and most of the
// smooth avalanche signal, and the median ignores the few large values at event edges; for white
// noise of standard deviation sigma, var(d2) = 6 sigma^2. See docs/analysis.md.
#pragma once
#include <cstddef>
#include <optional>
#include <span>
#include <vector>

namespace biodem::analysis {

/// Default rebound fraction rho (docs/analysis.md section 3: chosen from the threshold study).
inline constexpr double kDefaultReboundFraction = 0.15;

struct EventParams {
  std::optional<double> min_drop_deg;  // explicit threshold h; overrides the noise-based default
  double noise_multiple = 8.0;         // k
  double floor_deg = 0.05;             // lower bound of the default threshold
  double rebound_fraction = kDefaultReboundFraction;  // rho: a minimum needs a rise of
                                                     // max(h, min(rho x drop so far, cap))
  double rebound_cap_deg = 1.0;        // cap of the rebound requirement
};

struct Event {
  std::size_t start_index;
  std::size_t end_index;
  double start_time_s;
  double start_revolution;             // NaN if the series has no revolution column
  double uas_deg;                      // alpha at the start
  double end_time_s;
  double drop_deg;                     // alpha(start) - alpha(end)
  std::optional<double> interval_s;    // to the next event's start; empty for the last event
  std::optional<double> f_percent;     // rpm * interval / 60 * 100
};

struct EventDetection {
  std::vector<Event> events;
  double threshold_deg;      // h actually used
  double noise_sigma_deg;    // robust noise estimate (NaN if fewer than 3 samples)
  bool threshold_from_noise; // true when the default rule chose h
  double rebound_fraction = 0.0;  // rho used
};

/// Robust sample-to-sample noise of a series (see above). NaN for fewer than 3 samples.
double estimate_noise_sigma(std::span<const double> alpha_deg);

/// Threshold from the default rule for a noise estimate.
double default_threshold_deg(double noise_sigma_deg, const EventParams& params);

/// Indices (start, end) of the events of alpha for a threshold h > 0 and a rebound fraction
/// rho >= 0 (0: the plain zig-zag, a minimum is confirmed by a rise of h): a minimum is confirmed
/// by a rise of max(h, min(rho x (alpha at the event's start - the minimum), rebound_cap_deg)).
std::vector<std::pair<std::size_t, std::size_t>> find_drops(std::span<const double> alpha_deg,
                                                            double threshold_deg,
                                                            double rebound_fraction = 0.0,
                                                            double rebound_cap_deg = 1.0);

/// Full event detection. `revolution` may be empty; rpm is used for f (f empty if rpm is NaN).
/// Throws std::invalid_argument if the spans differ in length or the threshold is not > 0.
EventDetection detect_events(std::span<const double> time_s, std::span<const double> revolution,
                             std::span<const double> alpha_deg, double rpm,
                             const EventParams& params);

}  // namespace biodem::analysis
