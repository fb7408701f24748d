#include "analysis/flowability.hpp"

#include <algorithm>
#include <cmath>
#include <span>
#include <sstream>
#include <string>

#include "core/error.hpp"

namespace biodem::analysis {

namespace {
std::string deg(double v) {
  std::ostringstream o;
  o.precision(3);
  o << v;
  return o.str();
}
std::string seconds(double v) {
  std::ostringstream o;
  o.precision(6);
  o << v;
  return o.str();
}
}  // namespace

double rpm_from_revolution(const Series& s) {
  if (s.revolution.size() != s.size())
    throw Error("cannot determine the drum speed: the series has no revolution column; give --rpm");
  std::vector<double> rates;
  for (std::size_t i = 0; i + 1 < s.size(); ++i) {
    const double dt = s.time_s[i + 1] - s.time_s[i];
    const double dr = s.revolution[i + 1] - s.revolution[i];
    if (dt > 0.0 && dr > 0.0 && std::isfinite(dr)) rates.push_back(dr / dt);
  }
  if (rates.empty())
    throw Error(
        "cannot determine the drum speed: the revolution column never increases; give --rpm");
  std::nth_element(rates.begin(), rates.begin() + static_cast<std::ptrdiff_t>(rates.size() / 2),
                   rates.end());
  const double median = rates[rates.size() / 2];
  // The median of the sample-to-sample slopes carries the rounding of the written columns
  // (revolution has 12 significant digits: about 1e-8 of a slope), enough to split the equal f
  // of two samples that differ only in length. The slope over the longest stretch of samples
  // turning at that speed (each step within 1e-6 of it) averages the rounding away.
  std::size_t best_i = 0, best_j = 0;
  for (std::size_t i = 0; i + 1 < s.size();) {
    std::size_t j = i;
    while (j + 1 < s.size()) {
      const double dt = s.time_s[j + 1] - s.time_s[j];
      const double dr = s.revolution[j + 1] - s.revolution[j];
      if (!(dt > 0.0) || !(std::abs(dr / dt - median) <= 1e-6 * median)) break;
      ++j;
    }
    if (j - i > best_j - best_i) best_i = i, best_j = j;
    i = j > i ? j : i + 1;
  }
  if (best_j > best_i)
    return 60.0 * (s.revolution[best_j] - s.revolution[best_i]) / (s.time_s[best_j] - s.time_s[best_i]);
  return 60.0 * median;
}

std::size_t unwrap_alpha(std::vector<double>& a) {
  std::size_t wraps = 0;
  double shift = 0.0, prev = a.empty() ? 0.0 : a[0];
  for (std::size_t i = 1; i < a.size(); ++i) {
    const double raw = a[i];
    if (raw - prev > 180.0) shift -= 360.0, ++wraps;
    else if (raw - prev < -180.0) shift += 360.0, ++wraps;
    prev = raw;
    a[i] = raw + shift;
  }
  return wraps;
}

FlowabilityResult analyze_flowability(const Series& s, const FlowabilityOptions& opt) {
  FlowabilityResult res;
  const std::size_t n = s.size();
  if (n < kMinSamples) {
    std::ostringstream m;
    m << "too few samples: the series has " << n << ", need at least " << kMinSamples;
    throw Error(m.str());
  }
  if (opt.rpm) {
    if (!(*opt.rpm > 0.0) || !std::isfinite(*opt.rpm)) throw Error("--rpm must be > 0");
    res.rpm = *opt.rpm;
  } else {
    res.rpm = rpm_from_revolution(s);
    res.rpm_from_series = true;
  }
  if (opt.events.min_drop_deg && !(*opt.events.min_drop_deg > 0.0 && std::isfinite(*opt.events.min_drop_deg)))
    throw Error("--min-drop-deg must be > 0 and finite");
  if (!(opt.events.rebound_fraction >= 0.0) || !std::isfinite(opt.events.rebound_fraction))
    throw Error("--rebound-fraction must be >= 0");
  if (opt.skip_s && !(*opt.skip_s >= 0.0)) throw Error("--skip-s must be >= 0");
  if (opt.skip_rev && !(*opt.skip_rev >= 0.0)) throw Error("--skip-rev must be >= 0");

  // The analysis starts where the drum starts turning (a simulation's settle phase has a
  // constant revolution), then skips the requested transient.
  std::size_t first = 0;
  const bool has_rev = s.revolution.size() == n;
  if (has_rev) {
    std::size_t i = 0;
    while (i + 1 < n && !(s.revolution[i + 1] > s.revolution[i])) ++i;
    if (i + 1 < n) first = i;  // a revolution column that never moves: analyse everything
  }
  const double t0 = s.time_s[first];
  const double r0 = has_rev ? s.revolution[first] : 0.0;
  std::size_t start = first;
  while (start < n && ((opt.skip_s && s.time_s[start] < t0 + *opt.skip_s - 1e-12) ||
                       (opt.skip_rev && has_rev && s.revolution[start] < r0 + *opt.skip_rev - 1e-12)))
    ++start;
  if (opt.skip_rev && !has_rev) throw Error("--skip-rev needs a revolution column");
  const std::size_t used = n - start;
  if (used < kMinSamples) {
    std::ostringstream m;
    m << "too few samples: " << used << " left to analyse";
    if (start > 0) m << " after skipping " << start << " of " << n;
    m << ", need at least " << kMinSamples;
    throw Error(m.str());
  }
  res.first_sample = start;
  res.samples_used = used;

  auto sub = [&](const std::vector<double>& v) {
    return v.size() == n ? std::span<const double>(v).subspan(start) : std::span<const double>{};
  };
  // alpha made continuous over the analysed samples only (the insertion and settle samples before
  // them, or a skipped transient, may wrap without the rotating bed being carried over the top).
  res.alpha_deg = s.alpha_deg;
  {
    std::vector<double> analysed(s.alpha_deg.begin() + static_cast<std::ptrdiff_t>(start), s.alpha_deg.end());
    res.alpha_wraps = unwrap_alpha(analysed);
    std::copy(analysed.begin(), analysed.end(), res.alpha_deg.begin() + static_cast<std::ptrdiff_t>(start));
  }
  res.detection = detect_events(sub(s.time_s), sub(s.revolution), sub(res.alpha_deg), res.rpm,
                                opt.events);
  for (auto& e : res.detection.events) {
    e.start_index += start;
    e.end_index += start;
  }

  for (const auto& e : res.detection.events) {
    res.values[0].push_back(e.uas_deg);
    res.values[1].push_back(e.drop_deg);
    if (e.f_percent) res.values[2].push_back(*e.f_percent);
  }
  // r^2 of the drum turning: the last sample of a rest phase before it (first > 0, the start of
  // the alpha analysis) shows the bed at rest, whose nearly horizontal surface gives a low r^2
  // that is not a property of the flow (docs/analysis.md section 4).
  const std::span<const double> r2s = sub(s.surface_r2);
  for (std::size_t k = 0; k < r2s.size(); ++k)
    if (std::isfinite(r2s[k]) && !(first > 0 && start + k == first)) res.values[3].push_back(r2s[k]);
  for (std::size_t k = 0; k < res.values.size(); ++k)
    res.distributions[k] = describe(res.values[k]);

  // A bed carried over the top of the drum (alpha made continuous across 270/-90 deg) turns with
  // the drum rather than avalanching: its "events" and descriptors do not describe avalanches
  // (docs/analysis.md section 3). (A bed lifted past 180 deg that then avalanches is not named:
  // the quick raw drum's cohesive needles do so, with UAS up to 202 deg.)
  if (res.alpha_wraps) {
    std::size_t first_wrap = start + 1;
    while (first_wrap < n && std::abs(s.alpha_deg[first_wrap] - s.alpha_deg[first_wrap - 1]) <= 180.0) ++first_wrap;
    res.warnings.push_back("the bed was carried over the top of the drum " + std::to_string(res.alpha_wraps) + " time" +
                           (res.alpha_wraps == 1 ? "" : "s") + " (first at t = " +
                           seconds(s.time_s[std::min(first_wrap, n - 1)]) +
                           " s; alpha made continuous across 270/-90 deg, so that UAS counts on past 270 deg): the bed "
                           "turns with the drum instead of avalanching, and its events and descriptors do not describe "
                           "avalanches");
  }
  if (res.detection.events.empty())
    res.warnings.push_back("no events found (threshold " +
                           deg(res.detection.threshold_deg) +
                           " deg); UAS, avalanche size and f are empty");
  else if (res.detection.events.size() == 1)
    res.warnings.push_back("only one event found: f needs two");
  // A short series: the noise behind the default threshold is estimated from a handful of second
  // differences, and the distributions hold a few values (SPEC 6's study: 3 revolutions).
  const bool short_series = used < kFewSamples;
  if (short_series)
    res.warnings.push_back("only " + std::to_string(used) + " samples analysed" +
                           (has_rev ? " (" + deg(s.revolution[n - 1] - s.revolution[start]) + " revolution)" : std::string()) +
                           ": too short for a reliable noise estimate (the default threshold) and distributions; "
                           "analyse a longer series, or give --min-drop-deg");
  if (res.detection.threshold_from_noise && res.detection.threshold_deg > 1.0 && !short_series)
    res.warnings.push_back("the series is noisy: the default event threshold is " +
                           deg(res.detection.threshold_deg) +
                           " deg, small (glass-bead) avalanches may be missed; see --min-drop-deg");
  return res;
}

std::vector<SweepRow> sweep_event_rule(const Series& s, const FlowabilityOptions& opt,
                                       const std::vector<double>& thresholds_deg,
                                       const std::vector<double>& rebound_fractions) {
  std::vector<SweepRow> rows;
  for (double rho : rebound_fractions)
    for (double h : thresholds_deg) {
      FlowabilityOptions o = opt;
      o.events.min_drop_deg = h;
      o.events.rebound_fraction = rho;
      const FlowabilityResult r = analyze_flowability(s, o);
      rows.push_back(SweepRow{rho, h, r.detection.events.size(), r.distributions[0].p50,
                              r.distributions[1].p50, r.distributions[2].p50});
    }
  return rows;
}

}  // namespace biodem::analysis
