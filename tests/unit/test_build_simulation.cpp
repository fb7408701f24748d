// From a case file to the engine's parameters (driver::build_simulation, make_pair_table): the
// effective moduli of two different materials against SPEC 2.1 written out here, the damping
// coefficient against its closed form, and the [contact] settings reaching the engine. (Every
// other test case gives all materials the same E and nu, and the physics tests build their pair
// parameters themselves, so a mix-up of the two materials, or a [contact] key dropped on the way
// to the engine, would pass them.)
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <utility>

#include "case_file/case_parser.hpp"
#include "driver/build_simulation.hpp"

using namespace biodem;

namespace {

std::string scene(const std::string& contact) {
  return R"([run]
dt_s = 1.0e-6
)" + contact + R"(
[[material]]
name = "soft"
density_kg_m3 = 1500
young_pa = 5e6
poisson = 0.3

[[material]]
name = "hard"
young_pa = 7e9
poisson = 0.2

[[pair]]
materials = ["soft", "soft"]
restitution = 0.5
sliding_friction = 0.4
rolling_friction = 0.1
cohesion_energy_density_j_m3 = 2000.0

[[pair]]
materials = ["hard", "soft"]
restitution = 0.8
sliding_friction = 0.6
rolling_friction = 0.2
cohesion_energy_density_j_m3 = 500.0

[[shape]]
name = "b"
kind = "sphere"
diameter_m = 1e-3

[[wall]]
kind = "plane"
material = "hard"
point_m = [0, 0, 0]
normal = [0, 1, 0]

[[particle]]
shape = "b"
material = "soft"
position_m = [0, 0.001, 0]

[[phase]]
name = "x"
steps = 1
)";
}

// SPEC 2.1 and the damping of SPEC 2.2, written out independently of src/contact.
double y_star(double e1, double n1, double e2, double n2) { return 1.0 / ((1 - n1 * n1) / e1 + (1 - n2 * n2) / e2); }
double g_star(double e1, double n1, double e2, double n2) {
  return 1.0 / (2 * (2 - n1) * (1 + n1) / e1 + 2 * (2 - n2) * (1 + n2) / e2);
}
double beta_of(double e) { return std::log(e) / std::sqrt(std::log(e) * std::log(e) + std::numbers::pi * std::numbers::pi); }

}  // namespace

TEST(BuildSimulation, PairTableOfTwoMaterialsFollowsSpec21) {
  const auto built = driver::build_simulation(case_file::parse_case(scene(""), "case.toml").config);
  const auto& t = built.sim->pair_table();
  const auto& ss = t(0, 0);  // soft / soft
  const auto& sh = t(0, 1);  // soft / hard
  ASSERT_TRUE(ss.defined && sh.defined);
  EXPECT_EQ(t(1, 0).y_eff_pa, sh.y_eff_pa);  // symmetric
  EXPECT_NEAR(ss.y_eff_pa, y_star(5e6, 0.3, 5e6, 0.3), 1e-9 * ss.y_eff_pa);
  EXPECT_NEAR(ss.g_eff_pa, g_star(5e6, 0.3, 5e6, 0.3), 1e-9 * ss.g_eff_pa);
  EXPECT_NEAR(sh.y_eff_pa, y_star(5e6, 0.3, 7e9, 0.2), 1e-9 * sh.y_eff_pa);
  EXPECT_NEAR(sh.g_eff_pa, g_star(5e6, 0.3, 7e9, 0.2), 1e-9 * sh.g_eff_pa);
  // Either material's nu in the other's term would show: soft's E with hard's nu gives 5.21e6.
  EXPECT_GT(std::abs(sh.y_eff_pa - y_star(5e6, 0.2, 7e9, 0.3)), 1e-4 * sh.y_eff_pa);
  EXPECT_NEAR(ss.beta, beta_of(0.5), 1e-12);
  EXPECT_NEAR(sh.beta, beta_of(0.8), 1e-12);
  EXPECT_LT(sh.beta, 0.0);  // ln e < 0: the sign the damping law expects
  EXPECT_EQ(ss.friction, 0.4);
  EXPECT_EQ(sh.friction, 0.6);
  EXPECT_EQ(ss.rolling_friction, 0.1);
  EXPECT_EQ(sh.rolling_friction, 0.2);
  EXPECT_EQ(ss.cohesion_energy_density_j_m3, 2000.0);
  EXPECT_EQ(sh.cohesion_energy_density_j_m3, 500.0);
  // Defaults: the reference friction rule and the wall-relative spin for EPSD2 at walls.
  EXPECT_FALSE(ss.tangential_reduce);
  EXPECT_FALSE(sh.tangential_reduce);
  EXPECT_FALSE(built.sim->wall_rolling_lab());
}

TEST(BuildSimulation, ContactSettingsReachTheEngine) {
  const auto built = driver::build_simulation(
      case_file::parse_case(scene("\n[contact]\ntangential_reduce = true\nwall_rolling_reference = \"lab\"\n"), "case.toml")
          .config);
  EXPECT_TRUE(built.sim->pair_table()(0, 0).tangential_reduce);
  EXPECT_TRUE(built.sim->pair_table()(0, 1).tangential_reduce);
  EXPECT_TRUE(built.sim->wall_rolling_lab());
}

// Coarse graining (SPEC 4): [insertion] coarse_grain = s multiplies every particle length, so a
// sphere's radius by s and its mass by s^3, and nothing else: E, nu, restitution, friction,
// rolling friction and the cohesion energy density reach the engine as written. (The cohesion
// and rolling tests pass radii already scaled; a CED or a friction scaled with s on the way to
// the engine would pass them.)
TEST(BuildSimulation, CoarseGrainScalesLengthsAndMassesOnly) {
  std::string text = scene("");
  text.replace(text.find("position_m = [0, 0.001, 0]"), 26, "position_m = [0, 0.010, 0]");  // clear of the wall at 4x
  text += "\n[[population]]\nshape = \"b\"\nmaterial = \"soft\"\nvolume_fraction = 1.0\n"
          "\n[insertion]\ncount = 1\ncoarse_grain = 4.0\nregion = \"box\"\nregion_min_m = [-0.05, 0.02, -0.05]\n"
          "region_max_m = [0.05, 0.1, 0.05]\n";
  const auto fine = driver::build_simulation(case_file::parse_case(scene(""), "case.toml").config);
  const auto coarse = driver::build_simulation(case_file::parse_case(text, "case.toml").config);
  ASSERT_EQ(fine.sim->spheres().size(), 1u);
  ASSERT_EQ(coarse.sim->spheres().size(), 1u);
  EXPECT_DOUBLE_EQ(fine.sim->spheres().radius_m[0], 0.5e-3);
  EXPECT_DOUBLE_EQ(coarse.sim->spheres().radius_m[0], 4 * 0.5e-3);
  const double m1 = 1500.0 * 4.0 / 3.0 * std::numbers::pi * std::pow(0.5e-3, 3);
  EXPECT_NEAR(fine.sim->bodies().mass_kg[0], m1, 1e-12 * m1);
  EXPECT_NEAR(coarse.sim->bodies().mass_kg[0], 64.0 * m1, 1e-12 * 64.0 * m1);
  for (auto [i, j] : {std::pair{0, 0}, std::pair{0, 1}}) {
    const auto& f = fine.sim->pair_table()(i, j);
    const auto& c = coarse.sim->pair_table()(i, j);
    EXPECT_EQ(c.y_eff_pa, f.y_eff_pa);
    EXPECT_EQ(c.g_eff_pa, f.g_eff_pa);
    EXPECT_EQ(c.beta, f.beta);
    EXPECT_EQ(c.friction, f.friction);
    EXPECT_EQ(c.rolling_friction, f.rolling_friction);
    EXPECT_EQ(c.cohesion_energy_density_j_m3, f.cohesion_energy_density_j_m3);
  }
  EXPECT_EQ(coarse.sim->pair_table()(0, 0).cohesion_energy_density_j_m3, 2000.0);
}
