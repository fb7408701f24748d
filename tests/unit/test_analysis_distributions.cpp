// Centiles, spans and ranking (SPEC 6) against hand-computed values.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "analysis/distributions.hpp"

using namespace biodem::analysis;

// Linear interpolation between order statistics (numpy's default): h = (n - 1) p.
// 1..10: h10 = 0.9 -> 1.9, h50 = 4.5 -> 5.5, h90 = 8.1 -> 9.1; span = 7.2 / 11.
TEST(AnalysisDistributions, CentilesAndSpanOfOneToTen) {
  std::vector<double> v{10, 9, 8, 7, 6, 5, 4, 3, 2, 1};
  const auto d = describe(v);
  EXPECT_EQ(d.count, 10u);
  EXPECT_NEAR(d.mean, 5.5, 1e-12);
  EXPECT_NEAR(d.p10, 1.9, 1e-12);
  EXPECT_NEAR(d.p50, 5.5, 1e-12);
  EXPECT_NEAR(d.p90, 9.1, 1e-12);
  EXPECT_NEAR(d.span, 7.2 / 11.0, 1e-12);
}

// {3, 1, 4, 1, 5} sorted {1, 1, 3, 4, 5}: h10 = 0.4 -> 1, h50 = 2 -> 3, h90 = 3.6 -> 4.6;
// span = 3.6 / 5.6; NaN values are ignored.
TEST(AnalysisDistributions, CentilesOfASmallSetIgnoreNaN) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> v{3, nan, 1, 4, 1, 5, nan};
  const auto d = describe(v);
  EXPECT_EQ(d.count, 5u);
  EXPECT_NEAR(d.mean, 2.8, 1e-12);
  EXPECT_NEAR(d.p10, 1.0, 1e-12);
  EXPECT_NEAR(d.p50, 3.0, 1e-12);
  EXPECT_NEAR(d.p90, 4.6, 1e-12);
  EXPECT_NEAR(d.span, 3.6 / 5.6, 1e-12);
}

TEST(AnalysisDistributions, SingleAndEmptySets) {
  const auto one = describe(std::vector<double>{42.0});
  EXPECT_EQ(one.count, 1u);
  EXPECT_DOUBLE_EQ(one.p10, 42.0);
  EXPECT_DOUBLE_EQ(one.p90, 42.0);
  EXPECT_DOUBLE_EQ(one.span, 0.0);
  const auto none = describe(std::vector<double>{});
  EXPECT_EQ(none.count, 0u);
  EXPECT_TRUE(std::isnan(none.mean));
  EXPECT_TRUE(std::isnan(none.p50));
  EXPECT_TRUE(std::isnan(none.span));
}

TEST(AnalysisDistributions, EmpiricalCdfIsSortedAndEndsAtOne) {
  const auto c = empirical_cdf(std::vector<double>{3, 1, 2, 2});
  ASSERT_EQ(c.value.size(), 4u);
  EXPECT_EQ(c.value, (std::vector<double>{1, 2, 2, 3}));
  EXPECT_DOUBLE_EQ(c.fraction.front(), 0.25);
  EXPECT_DOUBLE_EQ(c.fraction.back(), 1.0);
}

// Hand-made table of four samples (medians). Rank I = worst flow ... IV = best; ties share the
// lowest rank of their group ("1 2 2 4").
//            UAS (higher worse)  drop (higher worse)  f (higher worse)  r^2 (lower worse)
//   raw           45.0                 8.0                 3.0              0.90
//   mild          40.0                 8.0                 1.5              0.95
//   intense       45.0                 2.0                 0.5              0.99
//   glass         38.0                 0.5                 0.2              0.99
//   ranks  UAS: raw I, intense I, mild III, glass IV
//          drop: raw I, mild I, intense III, glass IV
//          f:    raw I, mild II, intense III, glass IV
//          r^2:  raw I, mild II, intense III, glass III
TEST(AnalysisDistributions, RankingOfFourSamplesWithTies) {
  const auto t = descriptor_table();
  ASSERT_EQ(t.size(), 4u);
  EXPECT_EQ(std::vector<int>(rank_samples(std::vector<double>{45.0, 40.0, 45.0, 38.0}, t[0].worse)),
            (std::vector<int>{1, 3, 1, 4}));
  EXPECT_EQ(rank_samples(std::vector<double>{8.0, 8.0, 2.0, 0.5}, t[1].worse),
            (std::vector<int>{1, 1, 3, 4}));
  EXPECT_EQ(rank_samples(std::vector<double>{3.0, 1.5, 0.5, 0.2}, t[2].worse),
            (std::vector<int>{1, 2, 3, 4}));
  EXPECT_EQ(rank_samples(std::vector<double>{0.90, 0.95, 0.99, 0.99}, t[3].worse),
            (std::vector<int>{1, 2, 3, 3}));
  // A sample without data is not ranked.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(rank_samples(std::vector<double>{nan, 2.0, 1.0}, WorseWhen::higher),
            (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(roman(1), "I");
  EXPECT_EQ(roman(4), "IV");
  EXPECT_EQ(roman(9), "IX");
  EXPECT_EQ(roman(0), "-");
}
