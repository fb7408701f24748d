// Avalanche events on synthetic centroid-angle series with planted events (SPEC 6): every
// planted event is found, none is invented, UAS, drop and f are exact to the sampling precision.
#include <gtest/gtest.h>

#include <algorithm>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "analysis/events.hpp"
#include "analysis/flowability.hpp"
#include "core/error.hpp"
#include "output/series_csv.hpp"
#include "test_analysis_helpers.hpp"

using namespace biodem;
using namespace biodem::analysis;

namespace {

constexpr double kDt = 0.02;     // 50 Hz, as the camera
constexpr double kRpm = 0.5;     // the study's drum speed
constexpr double kRise = kRpm * 360.0 / 60.0 * kDt;  // 0.06 deg per sample of solid-body rise

struct Planted {
  std::size_t peak;      // sample index of the maximum
  double drop_deg;
  std::size_t duration;  // samples from the maximum to the minimum
};

struct Synthetic {
  std::vector<double> t, rev, clean, alpha;
};

// alpha rises with the drum at kRise per sample and falls linearly during each planted event.
Synthetic sawtooth(const std::vector<Planted>& ev, std::size_t n, double noise, std::uint64_t seed,
                   double alpha0 = 40.0) {
  Synthetic s;
  test::Noise rng(seed);
  s.clean.assign(n, alpha0);
  for (std::size_t i = 1; i < n; ++i) {
    double step = kRise;
    for (const auto& e : ev)
      if (i > e.peak && i <= e.peak + e.duration) step = -e.drop_deg / static_cast<double>(e.duration);
    s.clean[i] = s.clean[i - 1] + step;
  }
  for (std::size_t i = 0; i < n; ++i) {
    s.t.push_back(static_cast<double>(i) * kDt);
    s.rev.push_back(kRpm * s.t.back() / 60.0);
    s.alpha.push_back(s.clean[i] + rng.uniform(noise));
  }
  return s;
}

// Glass-bead-like events (tenths of a degree) mixed with biomass-like ones (several degrees).
const std::vector<Planted> kMixed{{100, 0.4, 2},  {180, 0.3, 2},  {230, 0.25, 1}, {400, 12.0, 25},
                                  {700, 0.5, 4},  {760, 5.0, 10}, {950, 0.2, 3}};

}  // namespace

// Tolerances: start/end indices exact (the rise per sample, 0.06 deg, exceeds twice the noise
// amplitude, 0.01 deg, so noise cannot move an extremum); UAS within the noise amplitude; drop
// within twice it; interval and f to rounding.
TEST(AnalysisEvents, PlantedMixedEventsAreFoundExactly) {
  const double a = 0.01;
  const auto s = sawtooth(kMixed, 1100, a, 7);
  const auto det = detect_events(s.t, s.rev, s.alpha, kRpm, EventParams{});
  EXPECT_TRUE(det.threshold_from_noise);
  EXPECT_LT(det.threshold_deg, 0.2) << "the default must keep glass-bead events";
  EXPECT_GE(det.threshold_deg, 2.0 * a) << "the default must be above the noise";
  ASSERT_EQ(det.events.size(), kMixed.size());
  for (std::size_t k = 0; k < kMixed.size(); ++k) {
    const auto& e = det.events[k];
    const auto& p = kMixed[k];
    EXPECT_EQ(e.start_index, p.peak) << "event " << k;
    EXPECT_EQ(e.end_index, p.peak + p.duration) << "event " << k;
    EXPECT_DOUBLE_EQ(e.start_time_s, static_cast<double>(p.peak) * kDt);
    EXPECT_NEAR(e.uas_deg, s.clean[p.peak], a + 1e-12) << "event " << k;
    EXPECT_NEAR(e.drop_deg, p.drop_deg, 2 * a + 1e-12) << "event " << k;
    EXPECT_NEAR(e.start_revolution, kRpm * e.start_time_s / 60.0, 1e-12);
    if (k + 1 < kMixed.size()) {
      const double T = static_cast<double>(kMixed[k + 1].peak - p.peak) * kDt;
      ASSERT_TRUE(e.interval_s.has_value());
      EXPECT_NEAR(*e.interval_s, T, 1e-9);
      ASSERT_TRUE(e.f_percent.has_value());
      EXPECT_NEAR(*e.f_percent, kRpm * T / 60.0 * 100.0, 1e-9);
    } else {
      EXPECT_FALSE(e.interval_s.has_value());
      EXPECT_FALSE(e.f_percent.has_value());
    }
  }
}

// Wiggles below the threshold (0.05 deg floor here): a 0.03 deg rebound inside a slow drop must
// not split it, a 0.03 deg dip during the rise must not become an event.
TEST(AnalysisEvents, WigglesBelowThresholdNeitherCreateNorSplitEvents) {
  const std::vector<Planted> ev{{100, 0.4, 2}, {400, 3.0, 100}, {700, 0.3, 3}};
  auto s = sawtooth(ev, 900, 0.005, 11);
  s.alpha[450] += 0.06;  // drop step is 0.03 per sample: a rebound of 0.03 deg
  s.alpha[300] -= 0.09;  // rise is 0.06 per sample: a dip of 0.03 deg
  const auto det = detect_events(s.t, s.rev, s.alpha, kRpm, EventParams{});
  EXPECT_DOUBLE_EQ(det.threshold_deg, 0.05);
  ASSERT_EQ(det.events.size(), 3u);
  EXPECT_EQ(det.events[1].start_index, 400u);
  EXPECT_EQ(det.events[1].end_index, 500u);
  EXPECT_NEAR(det.events[1].drop_deg, 3.0, 0.01 + 1e-12);
}

// An explicit threshold (--min-drop-deg) keeps only the larger drops; T is then the time between
// the starts of the retained events.
TEST(AnalysisEvents, ExplicitThresholdKeepsOnlyLargerDrops) {
  const auto s = sawtooth(kMixed, 1100, 0.01, 7);
  EventParams p;
  p.min_drop_deg = 1.0;
  const auto det = detect_events(s.t, s.rev, s.alpha, kRpm, p);
  EXPECT_FALSE(det.threshold_from_noise);
  ASSERT_EQ(det.events.size(), 2u);
  EXPECT_EQ(det.events[0].start_index, 400u);
  EXPECT_EQ(det.events[1].start_index, 760u);
  EXPECT_NEAR(*det.events[0].interval_s, 360 * kDt, 1e-9);
}

// The threshold's edge (SPEC 6: drops smaller than the threshold are not events): a drop of
// exactly h is an event, one of 0.75 h is not. Values exact in binary, so the comparison itself is
// tested: a strict "< max - h" would find no event here.
TEST(AnalysisEvents, DropOfExactlyTheThresholdIsAnEventASmallerOneIsNot) {
  const std::vector<double> a{10.0, 11.0, 10.0, 11.0, 12.0, 11.0, 13.0, 14.0, 13.25};
  std::vector<double> t, rev;
  for (std::size_t i = 0; i < a.size(); ++i) {
    t.push_back(static_cast<double>(i) * kDt);
    rev.push_back(kRpm * t.back() / 60.0);
  }
  EventParams p;
  p.min_drop_deg = 1.0;
  const auto det = detect_events(t, rev, a, kRpm, p);
  ASSERT_EQ(det.events.size(), 2u);
  EXPECT_EQ(det.events[0].start_index, 1u);
  EXPECT_EQ(det.events[0].end_index, 2u);
  EXPECT_EQ(det.events[0].drop_deg, 1.0);
  EXPECT_EQ(det.events[1].start_index, 4u);
  EXPECT_EQ(det.events[1].end_index, 5u);
  EXPECT_EQ(det.events[1].uas_deg, 12.0);
  p.min_drop_deg = 1.0 + 1.0 / 1024.0;  // just above both drops: none is an event
  EXPECT_TRUE(detect_events(t, rev, a, kRpm, p).events.empty());
}

// A series that begins inside an avalanche: its first maximum is not a real one (no rise of the
// threshold before it), so that partial event is not counted.
TEST(AnalysisEvents, SeriesStartingInsideAnAvalancheSkipsThePartialEvent) {
  const auto s = sawtooth({{0, 3.0, 20}, {300, 2.0, 10}, {600, 1.0, 5}}, 800, 0.01, 3);
  const auto det = detect_events(s.t, s.rev, s.alpha, kRpm, EventParams{});
  ASSERT_EQ(det.events.size(), 2u);
  EXPECT_EQ(det.events[0].start_index, 300u);
  EXPECT_EQ(det.events[1].start_index, 600u);
}

// The noise estimate (MAD of second differences) ignores the drum's steady rise and the events;
// the default threshold 8 sigma then keeps 0.4 deg events in 0.02 deg Gaussian noise and invents
// none over 5000 samples. Tolerance: sigma within 15 %.
TEST(AnalysisEvents, NoiseEstimateIsRobustAndDefaultThresholdInventsNothing) {
  std::vector<Planted> ev;
  for (std::size_t k = 0; k < 40; ++k) ev.push_back({100 + 120 * k, k % 4 == 0 ? 6.0 : 0.4, 3});
  auto s = sawtooth(ev, 5000, 0.0, 1);
  test::Noise rng(99);
  for (std::size_t i = 0; i < s.alpha.size(); ++i) s.alpha[i] = s.clean[i] + rng.gaussian(0.02);
  const double sigma = estimate_noise_sigma(s.alpha);
  EXPECT_NEAR(sigma, 0.02, 0.003);
  const auto det = detect_events(s.t, s.rev, s.alpha, kRpm, EventParams{});
  EXPECT_NEAR(det.threshold_deg, 8.0 * sigma, 1e-12);
  ASSERT_EQ(det.events.size(), ev.size());
  for (std::size_t k = 0; k < ev.size(); ++k) {
    EXPECT_LE(std::abs(static_cast<long>(det.events[k].start_index) - static_cast<long>(ev[k].peak)), 2);
    EXPECT_NEAR(det.events[k].drop_deg, ev[k].drop_deg, 0.15);
  }
}

TEST(AnalysisEvents, NoiseFreeSeriesUsesTheFloor) {
  const auto s = sawtooth({{100, 0.1, 1}, {200, 0.1, 1}}, 300, 0.0, 1);
  const auto det = detect_events(s.t, s.rev, s.alpha, kRpm, EventParams{});
  EXPECT_DOUBLE_EQ(det.threshold_deg, EventParams{}.floor_deg);
  EXPECT_EQ(det.events.size(), 2u);
}

TEST(AnalysisEvents, EmptyAndConstantSeriesHaveNoEvents) {
  EXPECT_TRUE(find_drops(std::vector<double>{}, 0.1).empty());
  EXPECT_TRUE(find_drops(std::vector<double>(100, 42.0), 0.1).empty());
  EXPECT_THROW(find_drops(std::vector<double>{1, 2, 3}, 0.0), std::invalid_argument);
}

// The whole analysis of one series: speed from the revolution column, a settle phase (drum at
// rest, revolution constant) is not analysed, --skip-s removes the first seconds of rotation.
TEST(AnalysisFlowability, SpeedSettlePhaseAndSkip) {
  const auto r = sawtooth(kMixed, 1100, 0.01, 7);
  Series s;
  // 100 samples of settling: the bed slumps by 3 deg, revolution stays 0.
  for (std::size_t i = 0; i < 100; ++i) {
    s.time_s.push_back(static_cast<double>(i) * kDt);
    s.revolution.push_back(0.0);
    s.alpha_deg.push_back(i < 50 ? 43.0 : 40.0);
  }
  for (std::size_t i = 0; i < r.t.size(); ++i) {
    s.time_s.push_back(r.t[i] + 100 * kDt);
    s.revolution.push_back(r.rev[i]);
    s.alpha_deg.push_back(r.alpha[i]);
  }
  FlowabilityOptions o;
  auto res = analyze_flowability(s, o);
  EXPECT_TRUE(res.rpm_from_series);
  EXPECT_NEAR(res.rpm, kRpm, 1e-9);
  EXPECT_EQ(res.first_sample, 100u);  // the last sample at rest
  ASSERT_EQ(res.detection.events.size(), kMixed.size());
  EXPECT_EQ(res.detection.events[0].start_index, 100 + kMixed[0].peak);
  EXPECT_EQ(res.values[0].size(), kMixed.size());
  EXPECT_EQ(res.values[2].size(), kMixed.size() - 1);
  EXPECT_EQ(res.distributions[3].count, 0u);  // no r^2 column

  o.skip_s = 5.0;  // drops the events at samples 100, 180 and 230 (t < 5 s after rotation starts)
  res = analyze_flowability(s, o);
  ASSERT_EQ(res.detection.events.size(), kMixed.size() - 3);
  EXPECT_EQ(res.detection.events[0].start_index, 100 + kMixed[3].peak);

  o.skip_s.reset();
  o.rpm = 1.0;  // given speed wins over the column
  res = analyze_flowability(s, o);
  EXPECT_FALSE(res.rpm_from_series);
  EXPECT_NEAR(*res.detection.events[0].f_percent, 1.0 * 80 * kDt / 60.0 * 100.0, 1e-9);

  // r^2 while the drum turns: 0.05 at rest (settling), 0.9 turning. The last rest sample, where
  // the alpha analysis starts, is not part of the r^2 distribution (before: 1 of 1,101 values
  // was 0.05).
  o.rpm.reset();
  s.surface_r2.assign(s.size(), 0.9);
  for (std::size_t i = 0; i <= 100; ++i) s.surface_r2[i] = 0.05;
  res = analyze_flowability(s, o);
  EXPECT_EQ(res.distributions[3].count, s.size() - 101);
  EXPECT_DOUBLE_EQ(res.distributions[3].p10, 0.9);
  EXPECT_DOUBLE_EQ(*std::min_element(res.values[3].begin(), res.values[3].end()), 0.9);
  // A series without a rest phase (a video's) keeps its first sample.
  Series v;
  for (std::size_t i = 100; i < s.size(); ++i) {
    v.time_s.push_back(s.time_s[i]);
    v.revolution.push_back(s.revolution[i]);
    v.alpha_deg.push_back(s.alpha_deg[i]);
    v.surface_r2.push_back(i == 100 ? 0.5 : 0.9);
  }
  res = analyze_flowability(v, o);
  EXPECT_EQ(res.first_sample, 0u);
  EXPECT_EQ(res.distributions[3].count, v.size());
}

// The drum speed from a written series (time and revolution with 12 significant digits, as
// series.csv has them): the same drum at 0.37 rpm and 50 Hz after settle phases of different
// lengths gives the same speed to 1e-10 (before, the median of the sample-to-sample slopes
// carried the columns' rounding, about 1e-8, and `compare` ranked equal f medians apart); a stop
// of the drum inside the series does not move it.
TEST(AnalysisFlowability, SpeedFromWrittenColumnsIsFreeOfTheirRounding) {
  auto written = [](double v) { return std::stod(biodem::output::csv_number(v, 12)); };
  std::vector<double> speeds;
  for (int settle : {0, 1013, 7391, 15000}) {
    Series s;
    const int n = settle + 300 * (1 + settle % 7);
    for (int i = 0; i < n; ++i) {
      const double t = i / 50.0;
      s.time_s.push_back(written(t));
      s.revolution.push_back(written(i < settle ? 0.0 : 0.37 * ((i - settle) / 50.0) / 60.0));
      s.alpha_deg.push_back(40.0);
    }
    const double rpm = rpm_from_revolution(s);
    EXPECT_NEAR(rpm, 0.37, 1e-10 * 0.37) << "settle " << settle;
    speeds.push_back(rpm);
    // A stop of 200 samples in the middle (revolution constant), then the same speed again.
    Series p = s;
    for (std::size_t i = p.size() / 2; i < p.size(); ++i) p.revolution[i] = written(s.revolution[i] - 200 * 0.37 / 50.0 / 60.0);
    for (std::size_t i = p.size() / 2; i < p.size() / 2 + 200 && i < p.size(); ++i) p.revolution[i] = p.revolution[p.size() / 2 - 1];
    EXPECT_NEAR(rpm_from_revolution(p), 0.37, 1e-10 * 0.37) << "settle " << settle << " with a stop";
  }
}

// A series too short to be read (under 50 analysed samples) is analysed with a warning that
// says so, instead of the "noisy series" warning its few second differences gave before; a
// threshold of inf is refused as 0 is.
TEST(AnalysisFlowability, ShortSeriesIsSaidToBeShort) {
  Series s;
  for (int i = 0; i < 10; ++i) {
    s.time_s.push_back(0.02 * i);
    s.revolution.push_back(0.02 * i * 10.0 / 60.0);
    s.alpha_deg.push_back(30.0 + (i % 3 == 0 ? 3.0 : 0.0));
  }
  auto res = analyze_flowability(s, FlowabilityOptions{});
  std::string all;
  for (const auto& w : res.warnings) all += w + "\n";
  EXPECT_NE(all.find("only 10 samples analysed (0.03 revolution): too short"), std::string::npos) << all;
  EXPECT_EQ(all.find("the series is noisy"), std::string::npos) << all;
  for (int i = 10; i < 60; ++i) {  // 60 samples: no such warning
    s.time_s.push_back(0.02 * i);
    s.revolution.push_back(0.02 * i * 10.0 / 60.0);
    s.alpha_deg.push_back(30.0 + (i % 3 == 0 ? 3.0 : 0.0));
  }
  res = analyze_flowability(s, FlowabilityOptions{});
  all.clear();
  for (const auto& w : res.warnings) all += w + "\n";
  EXPECT_EQ(all.find("too short"), std::string::npos) << all;
  FlowabilityOptions inf;
  inf.events.min_drop_deg = std::numeric_limits<double>::infinity();
  EXPECT_THROW(analyze_flowability(s, inf), Error);
}

TEST(AnalysisFlowability, BadInputsGiveClearErrors) {
  Series s;
  s.time_s = {0.0, 0.02};
  s.revolution = {0.0, 0.001};
  s.alpha_deg = {40.0, 40.1};
  try {
    analyze_flowability(s, {});
    FAIL() << "two samples accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("too few samples"), std::string::npos) << e.what();
  }
  s.time_s = {0.0, 0.02, 0.04, 0.06};
  s.revolution = {0.0, 0.0, 0.0, 0.0};
  s.alpha_deg = {40.0, 40.1, 40.2, 40.3};
  try {
    analyze_flowability(s, {});
    FAIL() << "speed invented";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--rpm"), std::string::npos) << e.what();
  }
  FlowabilityOptions o;
  o.rpm = 0.5;
  o.skip_s = 10.0;
  EXPECT_THROW(analyze_flowability(s, o), Error);
  o.skip_s.reset();
  o.events.min_drop_deg = -1.0;
  EXPECT_THROW(analyze_flowability(s, o), Error);
}

// Issue 12: biomass-like avalanches (4 to 15 deg over 12 to 30 samples) each with one rebound
// inside the collapse (alpha goes back up by 8 % of the drop so far, 0.16 to 0.6 deg: well above
// the 0.05 deg floor, so the plain zig-zag splits them), mixed with small glass-like events (0.2 to
// 0.5 deg, one pair only 0.12 deg of rise apart). The default rule counts each avalanche once, with
// its full drop, and still finds every glass-like event; the rule without rebound fraction
// (rho = 0) splits the avalanches.
TEST(AnalysisEvents, DefaultRuleCountsAvalanchesWithReboundsOnce) {
  struct Avalanche {
    std::size_t peak;
    double drop;
    std::size_t duration;
  };
  const std::vector<Avalanche> planted{{150, 0.3, 2},   {260, 8.0, 20},  {520, 0.25, 2}, {600, 0.45, 3},
                                       {605, 0.2, 2},   {760, 15.0, 30}, {1050, 4.0, 12}, {1250, 0.5, 4},
                                       {1400, 10.0, 25}};
  const std::size_t n = 1700;
  std::vector<double> t(n), rev(n), a(n, 130.0);
  for (std::size_t i = 1; i < n; ++i) {
    double step = kRise;
    for (const auto& e : planted)
      if (i > e.peak && i <= e.peak + e.duration) {
        const auto k = i - e.peak;  // 1 ... duration
        step = -e.drop / static_cast<double>(e.duration);
        // Big avalanches rebound once, half-way: alpha rises by 8 % of the drop so far.
        if (e.drop > 1.0 && k == e.duration / 2 + 1) step = 0.08 * e.drop / 2.0;
        if (e.drop > 1.0 && k == e.duration / 2 + 2) step = -2.0 * e.drop / static_cast<double>(e.duration) - 0.08 * e.drop / 2.0;
      }
    a[i] = a[i - 1] + step;
  }
  // Glass-like pair: the 0.2 deg event starts 2 samples (0.12 deg of rise) after the 0.45 deg one
  // ends: with rho up to 0.25 it stays a separate event.
  test::Noise rng(5);
  for (std::size_t i = 0; i < n; ++i) {
    t[i] = static_cast<double>(i) * kDt;
    rev[i] = kRpm * t[i] / 60.0;
    a[i] += rng.uniform(0.003);
  }
  const auto det = detect_events(t, rev, a, kRpm, EventParams{});
  EXPECT_DOUBLE_EQ(det.threshold_deg, 0.05);
  ASSERT_EQ(det.events.size(), planted.size());
  for (std::size_t k = 0; k < planted.size(); ++k) {
    EXPECT_EQ(det.events[k].start_index, planted[k].peak) << "event " << k;
    const double full = planted[k].drop;  // a rebound does not change the net drop
    EXPECT_NEAR(det.events[k].drop_deg, full, 0.01) << "event " << k;
  }
  EventParams plain;
  plain.rebound_fraction = 0.0;
  const auto split = detect_events(t, rev, a, kRpm, plain);
  EXPECT_EQ(split.events.size(), planted.size() + 4) << "rho = 0 splits each of the 4 avalanches";
}

// alpha lies in (-90, 270] deg: a bed carried over the top of the drum wrapped from 270 to -90
// deg, and the event rule counted a 359.9 deg "avalanche" with a UAS of 269.9 deg, ranked by
// compare without a word (a quick cohesive drum whose bed turned with the drum). alpha is made
// continuous before the events are found, and such a bed is named in a warning.
TEST(AnalysisFlowability, ABedCarriedOverTheTopIsNoAvalancheAndIsWarnedAbout) {
  std::vector<double> up = {260.0, 269.5, -89.5, -80.0}, down = {-80.0, -89.5, 269.5, 260.0};
  EXPECT_EQ(unwrap_alpha(up), 1u);
  EXPECT_EQ(up, (std::vector<double>{260.0, 269.5, 270.5, 280.0}));
  EXPECT_EQ(unwrap_alpha(down), 1u);
  EXPECT_EQ(down, (std::vector<double>{-80.0, -89.5, -90.5, -100.0}));

  // 10 rpm at 100 Hz (0.6 deg per sample): three 20 deg avalanches from 170 deg, then the bed
  // rides with the drum from 150 deg over the top (written as -90 deg on) and round to 170 deg
  // again, where it avalanches once more.
  Series s;
  double a = 150.0;
  auto push = [&](double alpha) {
    const std::size_t i = s.time_s.size();
    s.time_s.push_back(0.01 * static_cast<double>(i));
    s.revolution.push_back(0.01 * static_cast<double>(i) * 10.0 / 60.0);
    s.alpha_deg.push_back(alpha > 270.0 ? alpha - 360.0 : alpha);
  };
  for (int av = 0; av < 3; ++av) {
    while (a < 170.0) push(a += 0.6);
    for (int k = 0; k < 5; ++k) push(a -= 4.0);
  }
  while (a < 530.0) push(a += 0.6);
  for (int k = 0; k < 5; ++k) push(a -= 4.0);
  for (int k = 0; k < 20; ++k) push(a += 0.6);
  auto written = [&](double alpha) { return alpha > 270.0 ? alpha - 360.0 : alpha; };
  s.alpha_deg.clear();  // (written as the run writes it: 90 deg + atan2, in (-90, 270] deg)
  {
    double b = 150.0;
    for (int av = 0; av < 3; ++av) {
      while (b < 170.0) s.alpha_deg.push_back(written(b += 0.6));
      for (int k = 0; k < 5; ++k) s.alpha_deg.push_back(written(b -= 4.0));
    }
    while (b < 530.0) s.alpha_deg.push_back(written(std::fmod(b += 0.6, 360.0)));
    for (int k = 0; k < 5; ++k) s.alpha_deg.push_back(written(std::fmod(b -= 4.0, 360.0)));
    for (int k = 0; k < 20; ++k) s.alpha_deg.push_back(written(std::fmod(b += 0.6, 360.0)));
  }
  ASSERT_EQ(s.alpha_deg.size(), s.time_s.size());
  ASSERT_LT(*std::min_element(s.alpha_deg.begin(), s.alpha_deg.end()), -80.0);  // the wrap is written
  const auto res = analyze_flowability(s, FlowabilityOptions{});
  EXPECT_EQ(res.alpha_wraps, 1u);
  ASSERT_EQ(res.detection.events.size(), 4u);
  for (std::size_t k = 0; k < 4; ++k) {
    const auto& e = res.detection.events[k];
    EXPECT_NEAR(e.drop_deg, 20.0, 0.7);
    // The last one's UAS counts on past 270 deg (folded back to 170 it would pass for the same
    // flow as before the bed was carried round).
    EXPECT_NEAR(e.uas_deg, k < 3 ? 170.0 : 530.0, 1.0);
    EXPECT_EQ(res.alpha_deg[e.start_index], e.uas_deg);
  }
  std::string all;
  for (const auto& w : res.warnings) all += w + "\n";
  EXPECT_NE(all.find("carried over the top of the drum 1 time (first at t = 3.15 s"), std::string::npos) << all;
  // A wrap before the analysed samples (insertion, settling, a skipped transient) is not the
  // rotating bed's: analysed from after the wrap, the series is neither shifted nor warned about.
  FlowabilityOptions skip;
  skip.skip_s = 3.5;
  const auto later = analyze_flowability(s, skip);
  EXPECT_EQ(later.alpha_wraps, 0u);
  ASSERT_EQ(later.detection.events.size(), 1u);
  EXPECT_NEAR(later.detection.events[0].uas_deg, 170.0, 1.0);
  for (const auto& w : later.warnings) EXPECT_EQ(w.find("over the top"), std::string::npos) << w;
  EXPECT_EQ(later.alpha_deg[10], s.alpha_deg[10]);  // (the samples before are left as written)
  // A bed lifted past 180 deg that avalanches before the top is not named (the quick raw drum's
  // cohesive needles avalanche from up to 202 deg).
  Series high = s;
  high.time_s.resize(250), high.revolution.resize(250), high.alpha_deg.resize(250);  // up to 230 deg
  all.clear();
  for (const auto& w : analyze_flowability(high, FlowabilityOptions{}).warnings) all += w + "\n";
  EXPECT_EQ(all.find("over the top"), std::string::npos) << all;
}
