#include "analysis/distributions.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>

namespace biodem::analysis {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::vector<double> sorted_finite(std::span<const double> values) {
  std::vector<double> v;
  v.reserve(values.size());
  for (double x : values)
    if (std::isfinite(x)) v.push_back(x);
  std::sort(v.begin(), v.end());
  return v;
}
}  // namespace

double centile_sorted(std::span<const double> s, double p) {
  if (s.empty()) return kNaN;
  p = std::clamp(p, 0.0, 1.0);
  const double h = static_cast<double>(s.size() - 1) * p;
  const auto lo = static_cast<std::size_t>(std::floor(h));
  const std::size_t hi = std::min(lo + 1, s.size() - 1);
  return s[lo] + (h - static_cast<double>(lo)) * (s[hi] - s[lo]);
}

Distribution describe(std::span<const double> values) {
  const auto v = sorted_finite(values);
  Distribution d{0, kNaN, kNaN, kNaN, kNaN, kNaN};
  d.count = v.size();
  if (v.empty()) return d;
  d.mean = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
  d.p10 = centile_sorted(v, 0.10);
  d.p50 = centile_sorted(v, 0.50);
  d.p90 = centile_sorted(v, 0.90);
  const double sum = d.p90 + d.p10;
  d.span = sum != 0.0 ? (d.p90 - d.p10) / sum : kNaN;
  return d;
}

Cdf empirical_cdf(std::span<const double> values) {
  Cdf c;
  c.value = sorted_finite(values);
  const double n = static_cast<double>(c.value.size());
  c.fraction.resize(c.value.size());
  for (std::size_t i = 0; i < c.value.size(); ++i) c.fraction[i] = static_cast<double>(i + 1) / n;
  return c;
}

std::span<const DescriptorInfo> descriptor_table() {
  static const std::array<DescriptorInfo, 4> table{{
      {"uas_deg", "UAS (deg)", WorseWhen::higher},
      {"drop_deg", "avalanche size (deg)", WorseWhen::higher},
      {"f_percent", "f (% of a revolution)", WorseWhen::higher},
      {"surface_r2", "surface r^2", WorseWhen::lower},
  }};
  return table;
}

std::vector<int> rank_samples(std::span<const double> medians, WorseWhen worse) {
  const std::size_t n = medians.size();
  std::vector<int> rank(n, 0);
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < n; ++i)
    if (std::isfinite(medians[i])) order.push_back(i);
  // Worst first: descending medians when higher is worse, ascending otherwise.
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return worse == WorseWhen::higher ? medians[a] > medians[b] : medians[a] < medians[b];
  });
  auto tied = [&](double a, double b) {
    return std::abs(a - b) <= 1e-9 * std::max({1.0, std::abs(a), std::abs(b)});
  };
  for (std::size_t k = 0; k < order.size(); ++k) {
    if (k > 0 && tied(medians[order[k]], medians[order[k - 1]]))
      rank[order[k]] = rank[order[k - 1]];
    else
      rank[order[k]] = static_cast<int>(k + 1);
  }
  return rank;
}

std::string roman(int rank) {
  if (rank <= 0) return "-";
  static const std::array<std::pair<int, const char*>, 13> table{{{1000, "M"},
                                                                  {900, "CM"},
                                                                  {500, "D"},
                                                                  {400, "CD"},
                                                                  {100, "C"},
                                                                  {90, "XC"},
                                                                  {50, "L"},
                                                                  {40, "XL"},
                                                                  {10, "X"},
                                                                  {9, "IX"},
                                                                  {5, "V"},
                                                                  {4, "IV"},
                                                                  {1, "I"}}};
  std::string s;
  for (const auto& [v, sym] : table)
    while (rank >= v) {
      s += sym;
      rank -= v;
    }
  return s;
}

}  // namespace biodem::analysis
