#include "analysis/events.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace biodem::analysis {

namespace {

double median_of(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  double m = v[mid];
  if (v.size() % 2 == 0) {
    m = 0.5 * (m + *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid)));
  }
  return m;
}

}  // namespace

double estimate_noise_sigma(std::span<const double> a) {
  if (a.size() < 3) return std::numeric_limits<double>::quiet_NaN();
  std::vector<double> d2;
  d2.reserve(a.size() - 2);
  for (std::size_t i = 1; i + 1 < a.size(); ++i) d2.push_back(a[i + 1] - 2.0 * a[i] + a[i - 1]);
  const double med = median_of(d2);
  for (double& v : d2) v = std::abs(v - med);
  // 1.4826 * MAD estimates the standard deviation of a normal distribution.
  return 1.4826 * median_of(std::move(d2)) / std::sqrt(6.0);
}

double default_threshold_deg(double sigma, const EventParams& p) {
  const double from_noise = std::isfinite(sigma) ? p.noise_multiple * sigma : 0.0;
  return std::max(from_noise, p.floor_deg);
}

std::vector<std::pair<std::size_t, std::size_t>> find_drops(std::span<const double> a,
                                                            double h, double rebound_fraction,
                                                            double rebound_cap_deg) {
  if (!(h > 0.0)) throw std::invalid_argument("find_drops: threshold must be > 0");
  if (!(rebound_fraction >= 0.0) || !std::isfinite(rebound_fraction))
    throw std::invalid_argument("find_drops: rebound fraction must be >= 0");
  const double rho = rebound_fraction;
  const double cap = rebound_cap_deg;
  std::vector<std::pair<std::size_t, std::size_t>> out;
  const std::size_t n = a.size();
  if (n < 2) return out;

  enum class State { unknown, rising, falling } state = State::unknown;
  std::size_t imax = 0, imin = 0;
  double lowest_before_max = a[0];  // for the first maximum: did alpha rise by h up to it?
  bool open_event = false;          // a confirmed maximum waiting for its minimum
  std::size_t event_start = 0;

  auto close_event = [&](std::size_t end) {
    if (open_event) out.emplace_back(event_start, end);
    open_event = false;
  };

  for (std::size_t i = 1; i < n; ++i) {
    const double v = a[i];
    switch (state) {
      case State::unknown:
        if (v >= a[imax]) {
          imax = i;
          lowest_before_max = a[imin];
        }
        if (v < a[imin]) imin = i;
        if (v <= a[imax] - h) {
          // First confirmed extremum is a maximum: an event only if a rise of h preceded it.
          open_event = a[imax] - lowest_before_max >= h;
          event_start = imax;
          state = State::falling;
          imin = i;
        } else if (v >= a[imin] + h) {
          state = State::rising;
          imax = i;
        }
        break;
      case State::rising:
        if (v >= a[imax]) {
          imax = i;
        } else if (v <= a[imax] - h) {
          open_event = true;
          event_start = imax;
          state = State::falling;
          imin = i;
        }
        break;
      case State::falling:
        // The minimum is confirmed once alpha rose h above it and, with a rebound fraction rho,
        // rho times the drop so far (at most `cap`): a rebound inside a collapsing avalanche
        // does not end it. The cap keeps a long drift from swallowing later events.
        if (v < a[imin]) {
          imin = i;
        } else if (v >= a[imin] + std::max(h, std::min(rho * (a[event_start] - a[imin]), cap))) {
          close_event(imin);
          state = State::rising;
          imax = i;
        }
        break;
    }
  }
  if (state == State::falling) close_event(imin);
  return out;
}

EventDetection detect_events(std::span<const double> t, std::span<const double> rev,
                             std::span<const double> a, double rpm, const EventParams& p) {
  if (t.size() != a.size() || (!rev.empty() && rev.size() != a.size()))
    throw std::invalid_argument("detect_events: time, revolution and alpha differ in length");
  EventDetection det;
  det.noise_sigma_deg = estimate_noise_sigma(a);
  det.threshold_from_noise = !p.min_drop_deg.has_value();
  det.threshold_deg = p.min_drop_deg ? *p.min_drop_deg : default_threshold_deg(det.noise_sigma_deg, p);
  det.rebound_fraction = p.rebound_fraction;
  if (!(det.threshold_deg > 0.0))
    throw std::invalid_argument("detect_events: threshold must be > 0");

  if (!(p.rebound_fraction >= 0.0) || !std::isfinite(p.rebound_fraction))
    throw std::invalid_argument("detect_events: rebound fraction must be >= 0");
  for (const auto& [s, e] : find_drops(a, det.threshold_deg, p.rebound_fraction, p.rebound_cap_deg)) {
    Event ev{};
    ev.start_index = s;
    ev.end_index = e;
    ev.start_time_s = t[s];
    ev.start_revolution = rev.empty() ? std::numeric_limits<double>::quiet_NaN() : rev[s];
    ev.uas_deg = a[s];
    ev.end_time_s = t[e];
    ev.drop_deg = a[s] - a[e];
    det.events.push_back(ev);
  }
  for (std::size_t k = 0; k + 1 < det.events.size(); ++k) {
    const double T = det.events[k + 1].start_time_s - det.events[k].start_time_s;
    det.events[k].interval_s = T;
    if (std::isfinite(rpm)) det.events[k].f_percent = rpm * T / 60.0 * 100.0;
  }
  return det;
}

}  // namespace biodem::analysis
