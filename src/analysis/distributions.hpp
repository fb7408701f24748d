// Distributions of a descriptor and ranking of samples (SPEC 6).
//
// Centiles use linear interpolation between order statistics (numpy's default "linear" method,
// Hyndman & Fan type 7): for the sorted values x_0 <= ... <= x_{n-1} and p in [0, 1],
//     h = (n - 1) p,   eps_p = x_floor(h) + (h - floor(h)) (x_floor(h)+1 - x_floor(h)).
// Span S = (eps90 - eps10) / (eps90 + eps10) (NaN when eps90 + eps10 = 0).
#pragma once
#include <cstddef>
#include <span>
#include <string>
#include <vector>

namespace biodem::analysis {

struct Distribution {
  std::size_t count = 0;  // finite values used (NaN values are ignored)
  double mean;
  double p10;
  double p50;
  double p90;
  double span;
};

/// Centile of already sorted finite values, p in [0, 1]; NaN if empty.
double centile_sorted(std::span<const double> sorted, double p);

/// count, mean, eps10, eps50, eps90 and span of the finite values (all NaN if none).
Distribution describe(std::span<const double> values);

/// Empirical cumulative distribution: sorted finite values and F_i = (i + 1) / n.
struct Cdf {
  std::vector<double> value;
  std::vector<double> fraction;
};
Cdf empirical_cdf(std::span<const double> values);

/// Which way a descriptor's median points to worse flow.
enum class WorseWhen { higher, lower };

/// The SPEC 6 descriptors, in the order they are reported.
struct DescriptorInfo {
  const char* name;    // column/row name: uas_deg, drop_deg, f_percent, surface_r2
  const char* label;   // for plots and tables
  WorseWhen worse;     // higher UAS, larger drop, larger f, lower r^2 mean worse flow
};
std::span<const DescriptorInfo> descriptor_table();

/// Ranks of samples from their medians: 1 = worst flow ... N = best. Equal medians (within a
/// relative 1e-9) share the lowest rank of their group (competition ranking "1 2 2 4"); a NaN
/// median gets rank 0 (unranked) and does not count among the N.
std::vector<int> rank_samples(std::span<const double> medians, WorseWhen worse);

/// Roman numeral for a rank (1 -> "I"); "-" for 0.
std::string roman(int rank);

}  // namespace biodem::analysis
