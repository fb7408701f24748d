// Drum smoke test (issue 2, verification 9): the small glass-bead drum settles, rotates and, once
// the drum has turned more than the beads' repose angle, the bed is tilted (alpha > 95 deg, and
// below 140 deg, far beyond any glass-bead repose state), no particle escapes, and the
// snapshots load in VTK's own reader.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "test_util.hpp"

using namespace biodem::testing;

TEST(DrumSmoke, GlassBeadsSettleRotateAndTilt) {
  const std::string out = fresh_dir("drum_smoke");
  const auto r = run_command(biodem_exe() + " run " + source_dir() + "/tests/cases/glass_smoke.toml --out " + out +
                             " --threads 1");
  ASSERT_EQ(r.status, 0) << r.output;

  auto series = read_csv(out + "/series.csv");
  const auto t = to_numbers(series["time_s"]);
  const auto rev = to_numbers(series["revolution"]);
  const auto alpha = to_numbers(series["alpha_deg"]);
  const auto contacts = to_numbers(series["contacts"]);
  ASSERT_GT(t.size(), 20u);
  // Before rotation: a bed at rest gives alpha ~ 90 deg (within 3 deg: random packing).
  std::size_t last_settle = 0;
  for (std::size_t i = 0; i < rev.size(); ++i)
    if (rev[i] == 0.0) last_settle = i;
  EXPECT_NEAR(alpha[last_settle], 90.0, 3.0);
  // The drum turned 0.12 rev = 43 deg, more than the repose angle (~25 deg): the bed is tilted.
  EXPECT_NEAR(rev.back(), 0.12, 0.005);
  int tilted = 0;
  for (std::size_t i = 0; i < rev.size(); ++i)
    if (rev[i] > 0.09) {
      EXPECT_GT(alpha[i], 95.0) << "at t = " << t[i];
      EXPECT_LT(alpha[i], 140.0) << "at t = " << t[i];
      ++tilted;
    }
  EXPECT_GT(tilted, 3);
  EXPECT_GT(contacts.back(), 1781.0);  // a dense bed has more contacts than particles

  // No particle escapes: every traced body stays inside the drum (radius 15 mm, width 5 mm).
  auto trace = read_csv(out + "/trace.csv");
  const auto x = to_numbers(trace["x_m"]), y = to_numbers(trace["y_m"]), z = to_numbers(trace["z_m"]);
  ASSERT_FALSE(x.empty());
  double worst_r = 0.0, zmin = 1.0, zmax = -1.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    worst_r = std::max(worst_r, std::hypot(x[i], y[i]));
    zmin = std::min(zmin, z[i]);
    zmax = std::max(zmax, z[i]);
  }
  EXPECT_LT(worst_r, 0.015);
  EXPECT_GT(zmin, 0.0);
  EXPECT_LT(zmax, 0.005);

  // ParaView/VTK can read every snapshot with the SPEC 11 fields.
  const auto v = run_command(std::string(BIODEM_SYSTEM_PYTHON) + " " + source_dir() + "/tests/scripts/check_vtk.py " +
                             out + " 1781");
  EXPECT_EQ(v.status, 0) << v.output;
}
