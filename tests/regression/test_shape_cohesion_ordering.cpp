// Shape and cohesion ordering (SPEC 9; issue verification 6): in the same small drum, cohesive
// needle clumps stand at a clearly higher centroid angle than non-cohesive spheres of the same
// volume, once the drum has turned past both beds' repose angles.
//
// Cases: tests/cases/biomass_order_{needles_cohesive,spheres}.toml - raw biomass parameters,
// coarse-grained x4, 205 bodies in a 50 mm x 20 mm drum at 5 rpm, 0.6 revolution after settling;
// the two files differ only in the [[population]] shape and material. The two drums run in
// parallel, one thread each (about 70 s and 25 s of CPU).
//
// Measured when the test was written (mean alpha over revolutions 0.2-0.6 for [run] seed = 1, 2, 3):
//   cohesive needles      136.9 136.6 137.8 deg
//   non-cohesive spheres  128.0 129.7 129.5 deg
// margins 6.9-8.9 deg per seed, 6.9 deg for the worst pairing across seeds. With an earlier
// build and settle threshold (7e-12 J), seeds 1-6 gave needles 136.1-138.0 and spheres
// 127.3-129.4 deg (margins 7.9-9.3). The test asks for 5 deg. Larger or faster drums gave
// smaller margins (60 or 80 mm at 10 rpm: 6.5-6.9 deg; the faster turning lifts the spheres'
// dynamic angle more than the needles'), a 40 mm drum noisier ones (4.7-9.3 deg).
// Those figures were taken with cohesion inside the friction and rolling limits. Under the
// reference rule (SPEC 2.2, issue 20: cohesion kept out of the limits) the cohesive needles hold a
// much steeper bed: seed 1 settled at 85.5 deg (a poured cohesive bed is not flat) and then
// slumped in large events between ~140 and 180 deg, mean 163.0 deg, against 128.5 deg for the
// spheres (margin 34.5 deg). A bed carried round with the drum would pass 200 deg and keep going.
#include <gtest/gtest.h>

#include <cmath>
#include <future>
#include <iostream>
#include <numeric>
#include <string>
#include <vector>

#include "test_util.hpp"

using namespace biodem::testing;

namespace {

constexpr double kWindowFromRev = 0.2;  // past the repose angles: the beds reach their avalanche
                                        // regime by ~0.15 revolution (45-55 deg of turning)
constexpr double kMinMarginDeg = 5.0;

struct Drum {
  double settled_alpha = std::nan("");
  double mean_alpha = std::nan("");
  double last_rev = 0.0;
  std::size_t samples = 0;
};

Drum read_drum(const std::string& dir) {
  auto series = read_csv(dir + "/series.csv");
  const auto rev = to_numbers(series["revolution"]);
  const auto alpha = to_numbers(series["alpha_deg"]);
  Drum d;
  double sum = 0.0;
  for (std::size_t i = 0; i < rev.size(); ++i) {
    if (rev[i] == 0.0) d.settled_alpha = alpha[i];
    if (rev[i] >= kWindowFromRev) {
      sum += alpha[i];
      ++d.samples;
    }
  }
  if (!rev.empty()) d.last_rev = rev.back();
  if (d.samples) d.mean_alpha = sum / static_cast<double>(d.samples);
  return d;
}

}  // namespace

TEST(ShapeCohesionOrdering, CohesiveNeedlesStandHigherThanNonCohesiveSpheres) {
  const std::string out_needles = fresh_dir("order_needles_cohesive");
  const std::string out_spheres = fresh_dir("order_spheres");
  auto run = [](const std::string& file, const std::string& out) {
    return run_command(biodem_exe() + " run " + source_dir() + "/tests/cases/" + file + " --out " + out +
                       " --threads 1");
  };
  auto needles_job = std::async(std::launch::async, run, "biomass_order_needles_cohesive.toml", out_needles);
  auto spheres_job = std::async(std::launch::async, run, "biomass_order_spheres.toml", out_spheres);
  const auto rn = needles_job.get();
  const auto rs = spheres_job.get();
  ASSERT_EQ(rn.status, 0) << rn.output;
  ASSERT_EQ(rs.status, 0) << rs.output;

  const Drum needles = read_drum(out_needles);
  const Drum spheres = read_drum(out_spheres);
  // Both beds came to rest before the drum turned (the spheres flat, the cohesive needles within
  // a few degrees of flat), then turned 0.6 revolution.
  EXPECT_NEAR(needles.settled_alpha, 90.0, 7.0);
  EXPECT_NEAR(spheres.settled_alpha, 90.0, 3.0);
  EXPECT_NEAR(needles.last_rev, 0.6, 0.005);
  EXPECT_NEAR(spheres.last_rev, 0.6, 0.005);
  ASSERT_GT(needles.samples, 100u);
  ASSERT_GT(spheres.samples, 100u);
  // Both beds are tilted (past repose, not stuck to the wall going round).
  EXPECT_GT(spheres.mean_alpha, 110.0);
  EXPECT_LT(needles.mean_alpha, 190.0);

  std::cout << "mean alpha from revolution " << kWindowFromRev << ": cohesive needles " << needles.mean_alpha
            << " deg, non-cohesive spheres " << spheres.mean_alpha << " deg, margin "
            << needles.mean_alpha - spheres.mean_alpha << " deg\n";
  RecordProperty("needles_mean_alpha_deg", std::to_string(needles.mean_alpha));
  RecordProperty("spheres_mean_alpha_deg", std::to_string(spheres.mean_alpha));
  EXPECT_GE(needles.mean_alpha - spheres.mean_alpha, kMinMarginDeg)
      << "cohesive needles " << needles.mean_alpha << " deg vs spheres " << spheres.mean_alpha << " deg";
}
