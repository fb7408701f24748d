// A clockwise drum (rpm < 0) lifts its bed on the -x side; alpha must rise above 90 deg as for a
// counter-clockwise drum (SPEC 6: lifting the bed on the rising side increases alpha for either
// direction). The same tiny drum turned 0.06 revolution each way: both end well above 90 deg and
// within a few degrees of each other (the random packing is not mirror-symmetric). Before the
// fix, the clockwise drum ended near 70 deg.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "test_util.hpp"

using namespace biodem::testing;

namespace {
struct Final {
  double alpha = 0.0, surface_angle = 0.0;
};
Final final_state(const std::string& name, const std::string& rpm) {
  std::ifstream in(source_dir() + "/tests/cases/checkpoint_tiny.toml");
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  const std::string from = "rpm = 30.0";
  const auto pos = text.find(from);
  EXPECT_NE(pos, std::string::npos);
  text.replace(pos, from.size(), "rpm = " + rpm);
  const std::string dir = fresh_dir(name);
  std::filesystem::create_directories(dir);
  const std::string file = dir + "/case.toml";
  std::ofstream(file) << text;
  const auto r = run_command(biodem_exe() + " run " + file + " --out " + dir + "/out --threads 1");
  EXPECT_EQ(r.status, 0) << r.output;
  const auto csv = read_csv(dir + "/out/series.csv");
  const auto a = to_numbers(csv.at("alpha_deg")), s = to_numbers(csv.at("surface_angle_deg"));
  return {a.empty() ? 0.0 : a.back(), s.empty() ? 0.0 : s.back()};
}
}  // namespace

TEST(ClockwiseDrum, AlphaRisesForBothDirections) {
  const Final ccw = final_state("drum_ccw", "30.0"), cw = final_state("drum_cw", "-30.0");
  std::printf("[measured] after 0.06 revolution: alpha counter-clockwise %.2f deg, clockwise %.2f deg; surface "
              "angle %.2f and %.2f deg\n",
              ccw.alpha, cw.alpha, ccw.surface_angle, cw.surface_angle);
  EXPECT_GT(ccw.alpha, 100.0);
  EXPECT_GT(cw.alpha, 100.0);
  EXPECT_NEAR(cw.alpha, ccw.alpha, 5.0);
  // The surface angle too is measured on the rising side (as `video --rotation cw` reads it):
  // positive for both directions (before the fix the clockwise run wrote the lab's negative one).
  EXPECT_GT(ccw.surface_angle, 5.0);
  EXPECT_GT(cw.surface_angle, 5.0);
  EXPECT_NEAR(cw.surface_angle, ccw.surface_angle, 10.0);
}

// alpha is the angle of the powder's centre of MASS (SPEC 6): two beads of equal size, one of
// steel density (7,800 kg/m3) at x = +30 mm and one of 500 kg/m3 at x = -30 mm, both 20 mm below
// the axis (an explicit scene: alpha is measured about the origin, the drum axis of drum
// cases), no gravity. The mass-weighted centre gives x_c = 26.4 mm and alpha =
// 90 + atan2(26.4, 20) = 142.8 deg; the plain mean of the centres would give 90 deg. Read from
// the first row of series.csv (sampled right after the set-up); tolerance 1e-6 deg (9
// significant digits in the file).
TEST(ClockwiseDrum, AlphaIsTheAngleOfTheCentreOfMass) {
  const std::string dir = fresh_dir("alpha_mass_weighted");
  std::filesystem::create_directories(dir);
  const std::string file = dir + "/case.toml";
  std::ofstream(file) << R"([run]
dt_s = 1.0e-6
gravity_m_s2 = [0.0, 0.0, 0.0]

[[material]]
name = "steel_bead"
density_kg_m3 = 7800.0
young_pa = 1.0e7
poisson = 0.3

[[material]]
name = "light_bead"
density_kg_m3 = 500.0
young_pa = 1.0e7
poisson = 0.3

[[pair]]
materials = ["steel_bead", "steel_bead"]
restitution = 0.5
sliding_friction = 0.5
rolling_friction = 0.1

[[pair]]
materials = ["steel_bead", "light_bead"]
restitution = 0.5
sliding_friction = 0.5
rolling_friction = 0.1

[[pair]]
materials = ["light_bead", "light_bead"]
restitution = 0.5
sliding_friction = 0.5
rolling_friction = 0.1

[[shape]]
name = "bead"
kind = "sphere"
diameter_m = 2.0e-3

[[particle]]
shape = "bead"
material = "steel_bead"
position_m = [0.03, -0.02, 0.0]

[[particle]]
shape = "bead"
material = "light_bead"
position_m = [-0.03, -0.02, 0.0]

[[phase]]
name = "still"
steps = 10

[output]
sample_hz = 1.0e5
)";
  const auto r = run_command(biodem_exe() + " run " + file + " --out " + dir + "/out --threads 1");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto a = to_numbers(read_csv(dir + "/out/series.csv").at("alpha_deg"));
  ASSERT_FALSE(a.empty());
  const double m1 = 7800.0, m2 = 500.0;  // equal volumes: masses in proportion to the densities
  const double xc = (m1 * 0.03 + m2 * -0.03) / (m1 + m2), yc = -0.02;
  const double expected = 90.0 + std::atan2(xc, -yc) * 180.0 / 3.14159265358979323846;
  std::printf("[measured] alpha of two beads 7800/500 kg/m3: %.6f deg (centre of mass: %.6f)\n", a.front(), expected);
  EXPECT_NEAR(a.front(), expected, 1e-6);
  EXPECT_GT(a.front(), 140.0);
}
