// Case-file parsing and validation (SPEC 10, 11): every rule has a test asserting that the
// message names the key. Cases are inline TOML via parse_case; all tests run in milliseconds.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "contact/time_step.hpp"
#include "core/error.hpp"
#include "case_file/case_parser.hpp"
#include "config/steps.hpp"
#include "case_file/derived_quantities.hpp"
#include "output/case_report.hpp"
#include "output/output_dir.hpp"

using namespace biodem;

namespace {

// The example of SPEC 11, verbatim apart from the comments.
const std::string kSpecExample = R"(
[run]
dt_s = 1.5e-5
seed = 1
gravity_m_s2 = [0.0, -9.81, 0.0]

[[material]]
name = "bead"
density_kg_m3 = 2550.0
young_pa = 5.0e6
poisson = 0.22

[[material]]
name = "steel"
young_pa = 5.0e6
poisson = 0.22

[[material]]
name = "glass"
young_pa = 5.0e6
poisson = 0.22

[[pair]]
materials = ["bead", "bead"]
restitution = 0.87
sliding_friction = 0.2
rolling_friction = 0.0
cohesion_energy_density_j_m3 = 0.0

[[pair]]
materials = ["bead", "steel"]
restitution = 0.87
sliding_friction = 0.6
rolling_friction = 0.0
cohesion_energy_density_j_m3 = 0.0

[[pair]]
materials = ["bead", "glass"]
restitution = 0.87
sliding_friction = 0.2
rolling_friction = 0.0
cohesion_energy_density_j_m3 = 0.0

[[shape]]
name = "bead1mm"
kind = "sphere"
diameter_m = 1.0e-3

[[population]]
shape = "bead1mm"
material = "bead"
volume_fraction = 1.0

[insertion]
count = 19791
coarse_grain = 1.0

[drum]
diameter_m = 0.100
width_m = 0.005
rpm = 0.5
mantle_material = "steel"
endplate_material = "glass"

[[phase]]
name = "settle"
steps = 10000
rotate = false

[[phase]]
name = "rotate"
revolutions = 3.0

[output]
sample_hz = 50.0
snapshot_every_s = 1.0
checkpoint_every_s = 10.0
trace = false
)";

// An explicit scene: two beads above a floor.
const std::string kScene = R"(
[run]
dt_s = 1.0e-5

[[material]]
name = "bead"
density_kg_m3 = 2550
young_pa = 5e6
poisson = 0.22

[[material]]
name = "steel"
young_pa = 5e6
poisson = 0.22

[[pair]]
materials = ["bead", "bead"]
restitution = 0.9
sliding_friction = 0.3

[[pair]]
materials = ["steel", "bead"]
restitution = 0.9
sliding_friction = 0.3

[[shape]]
name = "b"
kind = "sphere"
diameter_m = 1e-3

[[wall]]
kind = "plane"
material = "steel"
point_m = [0, 0, 0]
normal = [0, 2, 0]

[[particle]]
shape = "b"
material = "bead"
position_m = [0, 0.001, 0]

[[particle]]
shape = "b"
material = "bead"
position_m = [0.002, 0.001, 0]
velocity_m_s = [0, -1, 0]

[[phase]]
name = "fall"
duration_s = 0.01
)";

/// `text` with the first occurrence of `from` replaced by `to` (which must exist).
std::string edit(std::string text, const std::string& from, const std::string& to) {
  const auto pos = text.find(from);
  if (pos == std::string::npos) throw std::logic_error("test bug: '" + from + "' not in the base case");
  return text.replace(pos, from.size(), to);
}

/// The error message of parsing `text`, or "" if it parses.
std::string error_of(const std::string& text) {
  try {
    case_file::parse_case(text, "case.toml");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

#define EXPECT_ERROR_NAMES(text, ...)                                              \
  do {                                                                             \
    const std::string msg_ = error_of(text);                                       \
    ASSERT_FALSE(msg_.empty()) << "expected an error";                             \
    EXPECT_EQ(msg_.find('\n'), std::string::npos) << "one line: " << msg_;        \
    EXPECT_EQ(msg_.rfind("case.toml", 0), 0u) << "names the file: " << msg_;      \
    for (const char* part_ : {__VA_ARGS__}) EXPECT_NE(msg_.find(part_), std::string::npos) << msg_; \
  } while (0)

}  // namespace

// ------------------------------------------------------------------ valid cases

TEST(CaseParser, SpecExampleParses) {
  const auto lc = case_file::parse_case(kSpecExample, "case.toml");
  const auto& c = lc.config;
  EXPECT_EQ(c.source_path, "case.toml");
  EXPECT_DOUBLE_EQ(c.run.dt_s, 1.5e-5);
  EXPECT_EQ(c.run.seed, 1u);
  EXPECT_EQ(c.materials.size(), 3u);
  EXPECT_FALSE(c.materials[1].density_kg_m3.has_value());
  ASSERT_EQ(c.pairs.size(), 3u);
  EXPECT_EQ(c.pairs[1].material_a, 0u);
  EXPECT_EQ(c.pairs[1].material_b, 1u);
  EXPECT_DOUBLE_EQ(c.pairs[1].sliding_friction, 0.6);
  ASSERT_EQ(c.shapes.size(), 1u);
  EXPECT_EQ(c.shapes[0].kind, config::ShapeKind::Sphere);
  ASSERT_TRUE(c.insertion && c.insertion->count);
  EXPECT_EQ(*c.insertion->count, 19791u);
  ASSERT_TRUE(c.drum);
  EXPECT_EQ(c.drum->mantle_material, 1u);
  EXPECT_EQ(c.drum->endplate_material, std::optional<std::size_t>(2));
  EXPECT_EQ(c.drum->axial_boundary, config::AxialBoundary::EndPlates);
  ASSERT_EQ(c.phases.size(), 2u);
  EXPECT_EQ(c.phases[0].length, config::PhaseLength::Steps);
  EXPECT_EQ(c.phases[0].steps, 10000u);
  EXPECT_FALSE(c.phases[0].rotate);
  EXPECT_EQ(c.phases[1].length, config::PhaseLength::Revolutions);
  EXPECT_TRUE(c.phases[1].rotate);  // default for revolutions
  ASSERT_TRUE(c.output.checkpoint_every_s);
  EXPECT_DOUBLE_EQ(*c.output.checkpoint_every_s, 10.0);
  // Glass beads at dt = 1.5e-5 s sit at ~25 % of the Rayleigh time: loads, with a warning.
  ASSERT_EQ(lc.warnings.size(), 1u);
  EXPECT_NE(lc.warnings[0].find("[run].dt_s"), std::string::npos) << lc.warnings[0];
}

// SPEC 11's case makes the snapshot and checkpoint keys optional in explicit scenes; a drum case
// without them loads, with a warning for each naming the key and what is not written (a drum
// run without checkpoints cannot resume after a kill); the explicit scene below has none.
TEST(CaseParser, DrumCaseWithoutCheckpointsOrSnapshotsWarns) {
  const auto lc = case_file::parse_case(
      edit(edit(kSpecExample, "checkpoint_every_s = 10.0", ""), "snapshot_every_s = 1.0", ""), "drum.toml");
  EXPECT_FALSE(lc.config.output.checkpoint_every_s);
  std::string all;
  for (const auto& w : lc.warnings) all += w + "\n";
  EXPECT_NE(all.find("drum.toml: [output].checkpoint_every_s is not given: no checkpoints"), std::string::npos) << all;
  EXPECT_NE(all.find("cannot be resumed"), std::string::npos) << all;
  EXPECT_NE(all.find("[output].snapshot_every_s is not given"), std::string::npos) << all;
  EXPECT_EQ(lc.warnings.size(), 3u) << all;  // (and the time step's, as with the keys)
}

TEST(CaseParser, ExplicitSceneParsesWithDefaults) {
  const auto lc = case_file::parse_case(kScene, "scene.toml");
  const auto& c = lc.config;
  EXPECT_TRUE(lc.warnings.empty());
  EXPECT_EQ(c.run.gravity_m_s2, (config::Vec3d{0.0, -9.81, 0.0}));
  EXPECT_EQ(c.run.seed, 1u);
  EXPECT_DOUBLE_EQ(*c.materials[0].density_kg_m3, 2550.0);  // integer accepted for a real key
  EXPECT_DOUBLE_EQ(c.pairs[0].rolling_friction, 0.0);
  EXPECT_DOUBLE_EQ(c.pairs[0].cohesion_energy_density_j_m3, 0.0);
  ASSERT_EQ(c.walls.size(), 1u);
  EXPECT_DOUBLE_EQ(c.walls[0].normal[1], 1.0);  // normalised
  ASSERT_EQ(c.particles.size(), 2u);
  EXPECT_EQ(c.particles[1].velocity_m_s, (config::Vec3d{0.0, -1.0, 0.0}));
  EXPECT_EQ(c.particles[0].orientation, (std::array<double, 4>{1, 0, 0, 0}));
  EXPECT_FALSE(c.insertion);
  EXPECT_FALSE(c.drum);
  EXPECT_DOUBLE_EQ(c.output.sample_hz, 50.0);
  EXPECT_EQ(c.phases[0].length, config::PhaseLength::Duration);
  EXPECT_FALSE(c.phases[0].rotate);
}

TEST(CaseParser, RealKeyAcceptsInteger) {
  const auto c = case_file::parse_case(edit(kSpecExample, "diameter_m = 0.100", "diameter_m = 1"), "case.toml").config;
  EXPECT_DOUBLE_EQ(c.drum->diameter_m, 1.0);
}

TEST(CaseParser, OrientationIsNormalised) {
  const auto c = case_file::parse_case(edit(kScene, "velocity_m_s = [0, -1, 0]", "orientation = [2, 0, 0, 2]"), "c").config;
  EXPECT_NEAR(c.particles[1].orientation[0], std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(c.particles[1].orientation[3], std::sqrt(0.5), 1e-15);
  EXPECT_ERROR_NAMES(edit(kScene, "velocity_m_s = [0, -1, 0]", "orientation = [0, 0, 0, 0]"), ".orientation");
}

TEST(CaseParser, NeedleAndClumpShapes) {
  std::string t = edit(kScene, "kind = \"sphere\"\ndiameter_m = 1e-3",
                       "kind = \"needle\"\nd50_m = 746e-6\naspect_ratio = 0.38");
  t = edit(t, "[0.002, 0.001, 0]", "[0.01, 0.01, 0]");
  t = edit(t, "[0, 0.001, 0]", "[0, 0.002, 0]");
  const auto c = case_file::parse_case(t, "case.toml").config;
  EXPECT_EQ(c.shapes[0].kind, config::ShapeKind::Needle);
  EXPECT_DOUBLE_EQ(c.shapes[0].overlap_factor, 0.2);
  const std::string clump = edit(kScene, "kind = \"sphere\"\ndiameter_m = 1e-3",
                                 "kind = \"clump\"\nspheres = [[0, 0, 0, 5e-4], [6e-4, 0, 0, 4e-4]]");
  const auto c2 = case_file::parse_case(edit(clump, "[0.002, 0.001, 0]", "[0.004, 0.001, 0]"), "case.toml").config;
  ASSERT_EQ(c2.shapes[0].spheres.size(), 2u);
  EXPECT_DOUBLE_EQ(c2.shapes[0].spheres[1].radius_m, 4e-4);
  EXPECT_ERROR_NAMES(edit(clump, "[6e-4, 0, 0, 4e-4]", "[6e-4, 0, 0, -4e-4]"), ".spheres", "radius");
  EXPECT_ERROR_NAMES(edit(clump, "[[0, 0, 0, 5e-4], [6e-4, 0, 0, 4e-4]]", "[]"), ".spheres");
}

TEST(CaseParser, NeedleOverlapFactorAboveHalfWarns) {
  std::string t = edit(kScene, "kind = \"sphere\"\ndiameter_m = 1e-3",
                       "kind = \"needle\"\nd50_m = 1e-3\naspect_ratio = 0.7\noverlap_factor = 0.6");
  t = edit(t, "[0.002, 0.001, 0]", "[0.01, 0.01, 0]");
  t = edit(t, "[0, 0.001, 0]", "[0, 0.002, 0]");
  const auto lc = case_file::parse_case(t, "case.toml");
  ASSERT_FALSE(lc.warnings.empty());
  EXPECT_NE(lc.warnings[0].find("overlap_factor"), std::string::npos);
  EXPECT_ERROR_NAMES(edit(t, "overlap_factor = 0.6", "overlap_factor = 1.0"), ".overlap_factor");
}

TEST(CaseParser, SettleCriterionPhase) {
  const std::string t = edit(kSpecExample, "steps = 10000",
                             "until_mean_kinetic_energy_j = 1e-10\nmax_duration_s = 1.0\nmin_duration_s = 0.3");
  const auto c = case_file::parse_case(t, "case.toml").config;
  ASSERT_TRUE(c.phases[0].until_mean_kinetic_energy_j);
  EXPECT_DOUBLE_EQ(*c.phases[0].max_duration_s, 1.0);
  EXPECT_DOUBLE_EQ(c.phases[0].min_duration_s, 0.3);
  EXPECT_DOUBLE_EQ(c.phases[0].duration_s, 1.0);  // the cap
  EXPECT_ERROR_NAMES(edit(kSpecExample, "steps = 10000", "until_mean_kinetic_energy_j = 1e-10"), ".max_duration_s");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "steps = 10000", "steps = 10\nduration_s = 1.0"), ".duration_s");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "steps = 10000", "steps = 10\nmax_duration_s = 1.0"), ".max_duration_s");
  // settle_energy: "total" by default, "translational" on request; anything else, or the key
  // without a criterion, is an error naming it.
  EXPECT_FALSE(c.phases[0].translational_criterion);
  const auto tr = case_file::parse_case(edit(t, "min_duration_s = 0.3", "min_duration_s = 0.3\nsettle_energy = \"translational\""),
                                 "case.toml").config;
  EXPECT_TRUE(tr.phases[0].translational_criterion);
  EXPECT_ERROR_NAMES(edit(t, "min_duration_s = 0.3", "min_duration_s = 0.3\nsettle_energy = \"rotational\""),
                     ".settle_energy");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "steps = 10000", "steps = 10\nsettle_energy = \"total\""), ".settle_energy");
}

TEST(CaseParser, PhaseRules) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "rpm = 0.5", "rpm = 0"), "[[phase]] #2 (rotate) .revolutions", "rpm");
  EXPECT_ERROR_NAMES(edit(kScene, "duration_s = 0.01", "revolutions = 1"), ".revolutions", "[drum]");
  EXPECT_ERROR_NAMES(edit(kScene, "name = \"fall\"\n", "name = \"fall\"\nrotate = true\n"), ".rotate");
  EXPECT_ERROR_NAMES(edit(kScene, "duration_s = 0.01", ""), "[[phase]] #1 (fall) .steps");
  EXPECT_ERROR_NAMES(edit(kScene, "[[phase]]\nname = \"fall\"\nduration_s = 0.01", ""), "[[phase]]");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "steps = 10000", "steps = 0"), ".steps");
  // Lengths the run cannot honour: a duration or a turn that rounds to no step, a settle phase
  // capped below half a step, a hold longer than the cap (the criterion could never be met).
  EXPECT_ERROR_NAMES(edit(kScene, "duration_s = 0.01", "duration_s = 1e-9"), "[[phase]] #1 (fall) .duration_s",
                     "less than half the time step", "no step");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "revolutions = 3.0", "revolutions = 1e-9"), ".revolutions", "no step");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "steps = 10000", "until_mean_kinetic_energy_j = 1e-10\nmax_duration_s = 1e-9"),
                     ".max_duration_s", "no step");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "steps = 10000",
                          "until_mean_kinetic_energy_j = 1e-10\nmax_duration_s = 0.5\nsettle_hold_s = 0.6"),
                     ".settle_hold_s", "could never be met");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "steps = 10000", "until_mean_kinetic_energy_j = 1e-10\nmax_duration_s = 0.005"),
                     ".max_duration_s", "settle_hold_s = 0.01 s", "(its default)");
  EXPECT_NO_THROW(case_file::parse_case(
      edit(kSpecExample, "steps = 10000", "until_mean_kinetic_energy_j = 1e-10\nmax_duration_s = 0.5\nsettle_hold_s = 0.5"),
      "case.toml"));
}

// ------------------------------------------------------------------ keys and types

TEST(CaseParser, UnknownKeyIsNamedWithSuggestion) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "diameter_m = 0.100", "diamter_m = 0.100"), "[drum].diamter_m",
                     "did you mean diameter_m");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "[output]", "[outptu]"), "[outptu]", "did you mean output");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "restitution = 0.87\nsliding_friction = 0.6",
                          "restitution = 0.87\nsliding_friction = 0.6\nstatic_friction = 1"),
                     "[[pair]] #2 (materials bead/steel) .static_friction");
}

TEST(CaseParser, KeyOfAnotherShapeKindIsRejected) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "diameter_m = 1.0e-3", "diameter_m = 1.0e-3\naspect_ratio = 0.5"),
                     "[[shape]] #1 (bead1mm) .aspect_ratio", "sphere");
}

TEST(CaseParser, MissingRequiredKeyIsNamed) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "width_m = 0.005\n", ""), "[drum].width_m", "missing");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "dt_s = 1.5e-5\n", ""), "[run].dt_s", "missing");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "young_pa = 5.0e6\n", ""), "[[material]] #1 (bead) .young_pa");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "[insertion]\ncount = 19791\ncoarse_grain = 1.0\n", ""), "[insertion]");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "endplate_material = \"glass\"", ""), "[drum].endplate_material");
}

TEST(CaseParser, MissingDensityOfParticleMaterialIsNamed) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "density_kg_m3 = 2550.0\n", ""), "[[material]] #1 (bead) .density_kg_m3");
}

TEST(CaseParser, WrongTypeIsNamed) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "diameter_m = 0.100", "diameter_m = \"big\""), "[drum].diameter_m",
                     "must be a number");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "trace = false", "trace = 0"), "[output].trace", "true or false");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "gravity_m_s2 = [0.0, -9.81, 0.0]", "gravity_m_s2 = [0.0, -9.81]"),
                     "[run].gravity_m_s2", "3 numbers");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "mantle_material = \"steel\"", "mantle_material = 3"),
                     "[drum].mantle_material", "string");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "[drum]", "[[drum]]"), "[drum]");
}

TEST(CaseParser, IntegerKeyRejectsReal) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "count = 19791", "count = 350.5"), "[insertion].count = 350.5",
                     "must be an integer");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "seed = 1", "seed = 2.0"), "[run].seed = 2.0", "integer");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "count = 19791", "count = 350.0"), "[insertion].count = 350.0",
                     "must be an integer");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "steps = 10000", "steps = 1e4"), ".steps = 10000.0", "integer");
}

TEST(CaseParser, IntegerKeyRejectsNegative) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "count = 19791", "count = -5"), "[insertion].count");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "seed = 1", "seed = -1"), "[run].seed");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "trace = false", "trace = false\nframe_size_px = 32"),
                     "[output].frame_size_px");
}

TEST(CaseParser, UnknownNameReferenceIsNamed) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "mantle_material = \"steel\"", "mantle_material = \"stel\""),
                     "[drum].mantle_material = \"stel\"", "steel");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "shape = \"bead1mm\"", "shape = \"bead2mm\""), "[[population]] #1 .shape");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "materials = [\"bead\", \"glass\"]", "materials = [\"bead\", \"glas\"]"),
                     ".materials");
}

// ------------------------------------------------------------------ ranges

TEST(CaseParser, NonPositiveDiameterIsRejected) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "diameter_m = 1.0e-3", "diameter_m = -1.0e-3"),
                     "[[shape]] #1 (bead1mm) .diameter_m", "> 0");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "diameter_m = 0.100", "diameter_m = 0"), "[drum].diameter_m");
}

TEST(CaseParser, NonPositiveDensityIsRejected) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "density_kg_m3 = 2550.0", "density_kg_m3 = 0"),
                     "[[material]] #1 (bead) .density_kg_m3 = 0");
}

TEST(CaseParser, NonPositiveModulusIsRejected) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "young_pa = 5.0e6", "young_pa = -5.0e6"), "[[material]] #1 (bead) .young_pa");
}

TEST(CaseParser, PoissonAtLeastHalfIsRejected) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "poisson = 0.22", "poisson = 0.5"), "[[material]] #1 (bead) .poisson = 0.5",
                     "< 0.5");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "poisson = 0.22", "poisson = -1.0"), ".poisson");
}

TEST(CaseParser, RestitutionOutsideUnitIntervalIsRejected) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "restitution = 0.87\nsliding_friction = 0.6", "restitution = 1.2\nsliding_friction = 0.6"),
                     "case.toml: [[pair]] #2 (materials bead/steel) .restitution = 1.2: must be in (0, 1]");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "restitution = 0.87", "restitution = 0"), "[[pair]] #1", ".restitution");
  EXPECT_TRUE(error_of(edit(kSpecExample, "restitution = 0.87", "restitution = 1")).empty());
}

TEST(CaseParser, NegativeFrictionIsRejected) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "sliding_friction = 0.2", "sliding_friction = -0.1"), ".sliding_friction",
                     ">= 0");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "rolling_friction = 0.0", "rolling_friction = -0.1"), ".rolling_friction");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "cohesion_energy_density_j_m3 = 0.0", "cohesion_energy_density_j_m3 = -1"),
                     ".cohesion_energy_density_j_m3");
}

TEST(CaseParser, AspectRatioAboveOneIsRejected) {
  const std::string t = edit(kSpecExample, "kind = \"sphere\"\ndiameter_m = 1.0e-3",
                             "kind = \"needle\"\nd50_m = 746e-6\naspect_ratio = 1.5");
  EXPECT_ERROR_NAMES(t, "[[shape]] #1 (bead1mm) .aspect_ratio = 1.5", "(0, 1]");
}

TEST(CaseParser, PopulationFractionsMustSumToOne) {
  const std::string two = edit(kSpecExample, "volume_fraction = 1.0",
                               "volume_fraction = 0.5\n\n[[population]]\nshape = \"bead1mm\"\nmaterial = \"bead\"\n"
                               "volume_fraction = 0.4");
  EXPECT_ERROR_NAMES(two, "volume_fraction", "sum to 0.9");
  EXPECT_TRUE(error_of(edit(two, "volume_fraction = 0.4", "volume_fraction = 0.5")).empty());
  EXPECT_ERROR_NAMES(edit(two, "volume_fraction = 0.4\n", ""), "[[population]] #2 .volume_fraction");
}

TEST(CaseParser, InsertionNeedsExactlyOneOfCountAndFill) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "count = 19791", "count = 19791\nfill_fraction = 0.4"),
                     "[insertion].fill_fraction");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "count = 19791", ""), "[insertion].count");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "count = 19791", "fill_fraction = 1.0"), "[insertion].fill_fraction");
}

// ------------------------------------------------------------------ cross-table rules

TEST(CaseParser, MissingPairTableIsNamed) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "materials = [\"bead\", \"glass\"]", "materials = [\"glass\", \"steel\"]"),
                     "[[pair]]", "bead", "glass", "end plates");
  EXPECT_ERROR_NAMES(edit(kScene, "materials = [\"bead\", \"bead\"]", "materials = [\"steel\", \"steel\"]"),
                     "[[pair]]", "\"bead\", \"bead\"");
}

TEST(CaseParser, DuplicatePairIsRejected) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "materials = [\"bead\", \"glass\"]", "materials = [\"steel\", \"bead\"]"),
                     "[[pair]] #3", ".materials", "duplicate");
}

TEST(CaseParser, PeriodicDrumNeedsNoEndplatePair) {
  std::string t = edit(kSpecExample, "endplate_material = \"glass\"", "axial_boundary = \"periodic\"");
  t = edit(t, "materials = [\"bead\", \"glass\"]", "materials = [\"glass\", \"glass\"]");
  const auto c = case_file::parse_case(t, "case.toml").config;
  EXPECT_EQ(c.drum->axial_boundary, config::AxialBoundary::Periodic);
  EXPECT_FALSE(c.drum->endplate_material);
}

TEST(CaseParser, PeriodicDrumMustHoldThreeCells) {
  std::string t = edit(kSpecExample, "endplate_material = \"glass\"", "axial_boundary = \"periodic\"");
  t = edit(t, "count = 19791", "count = 1000");
  // 3 x (1 mm + 0.125 mm default skin) = 3.375 mm <= 3.4 mm: fine; 3.3 mm is too narrow.
  t = edit(t, "width_m = 0.005", "width_m = 0.0034");
  EXPECT_TRUE(error_of(t).empty()) << error_of(t);
  EXPECT_ERROR_NAMES(edit(t, "width_m = 0.0034", "width_m = 0.0033"), "[drum].width_m", "periodic");
}

TEST(CaseParser, DtMustBePositive) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "dt_s = 1.5e-5", "dt_s = 0"), "[run].dt_s = 0", "> 0");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "dt_s = 1.5e-5", "dt_s = -1e-5"), "[run].dt_s");
}

TEST(CaseParser, DtAboveFortyPercentOfRayleighTimeIsRefused) {
  // Glass beads 1 mm: T_R = 6.07e-5 s.
  const double tr = contact::rayleigh_time_s(0.5e-3, 2550.0, 5e6, 0.22);
  EXPECT_NEAR(tr, 6.07e-5, 0.01e-5);
  const std::string t = edit(kSpecExample, "dt_s = 1.5e-5", "dt_s = 3.0e-5");
  EXPECT_ERROR_NAMES(t, "[run].dt_s = 3e-05", "Rayleigh", "allow_large_dt");
  const auto lc = case_file::parse_case(edit(t, "seed = 1", "seed = 1\nallow_large_dt = true"), "case.toml");
  ASSERT_EQ(lc.warnings.size(), 1u);
  EXPECT_NE(lc.warnings[0].find("[run].dt_s"), std::string::npos);
  EXPECT_NEAR(case_file::smallest_rayleigh_time_s(lc.config), tr, 1e-12);
}

// The Rayleigh time is that of a shape's smallest sphere: a clump of a 0.5 mm and a 0.125 mm
// sphere at dt = 1e-5 s is at 16.5 % of the large sphere's T_R (6.07e-5 s) but at 65.9 % of the
// small one's (1.52e-5 s), and is refused.
TEST(CaseParser, RayleighLimitUsesTheSmallestSphereOfAClump) {
  const double tr_small = contact::rayleigh_time_s(1.25e-4, 2550.0, 5e6, 0.22);
  EXPECT_NEAR(tr_small, 1.518e-5, 0.001e-5);
  const std::string clump = edit(kScene, "kind = \"sphere\"\ndiameter_m = 1e-3",
                                 "kind = \"clump\"\nspheres = [[0, 0, 0, 5e-4], [5e-4, 0, 0, 1.25e-4]]");
  EXPECT_ERROR_NAMES(clump, "[run].dt_s = 1e-05", "65.9 %", "shape b");
  EXPECT_TRUE(error_of(edit(clump, "dt_s = 1.0e-5", "dt_s = 2.0e-6")).empty());
}

TEST(CaseParser, DtBetweenTwentyAndFortyPercentWarns) {
  const auto lc = case_file::parse_case(kSpecExample, "case.toml");  // 24.7 %
  ASSERT_EQ(lc.warnings.size(), 1u);
  EXPECT_NE(lc.warnings[0].find("[run].dt_s"), std::string::npos);
  EXPECT_NE(lc.warnings[0].find("24.7 %"), std::string::npos) << lc.warnings[0];
  EXPECT_TRUE(case_file::parse_case(edit(kSpecExample, "dt_s = 1.5e-5", "dt_s = 1e-5"), "c").warnings.empty());
}

TEST(CaseParser, CountThatCannotBeInsertedIsRejected) {
  // Drum volume 3.93e-5 m^3; 1 mm beads: 5.24e-10 m^3 each; 55 % holds 41,250.
  EXPECT_ERROR_NAMES(edit(kSpecExample, "count = 19791", "count = 50000"), "[insertion].count = 50000", "55 %");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "width_m = 0.005", "width_m = 0.0009"), "[drum].width_m");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "diameter_m = 0.100", "diameter_m = 0.0009"), "[drum].diameter_m");
}

TEST(CaseParser, FillFractionImpliesCount) {
  const std::string t = edit(kSpecExample, "count = 19791", "fill_fraction = 0.4");
  const auto c = case_file::parse_case(t, "case.toml").config;
  const double v_drum = M_PI * 0.05 * 0.05 * 0.005, v_bead = M_PI / 6.0 * 1e-9;
  EXPECT_EQ(case_file::implied_particle_count(c), static_cast<std::uint64_t>(std::llround(0.4 * 0.6 * v_drum / v_bead)));
  EXPECT_ERROR_NAMES(edit(t, "fill_fraction = 0.4", "fill_fraction = 0.99\nbulk_solid_fraction = 0.9"),
                     "[insertion].fill_fraction", "55 %");
}

TEST(CaseParser, PolydisperseMeanVolumeIsNumberWeighted) {
  std::string t = edit(kSpecExample, "[[population]]\nshape = \"bead1mm\"\nmaterial = \"bead\"\nvolume_fraction = 1.0",
                       "[[population]]\nshape = \"bead1mm\"\nmaterial = \"bead\"\nvolume_fraction = 0.5\n"
                       "[[population]]\nshape = \"bead2mm\"\nmaterial = \"bead\"\nvolume_fraction = 0.5\n"
                       "[[shape]]\nname = \"bead2mm\"\nkind = \"sphere\"\ndiameter_m = 2e-3\n");
  t = edit(t, "count = 19791", "count = 1000");
  const auto c = case_file::parse_case(t, "case.toml").config;
  const double v1 = M_PI / 6.0 * 1e-9, v2 = 8.0 * v1;
  EXPECT_NEAR(case_file::mean_population_particle_volume_m3(c) / (1.0 / (0.5 / v1 + 0.5 / v2)), 1.0, 1e-12);
}

TEST(CaseParser, ExplicitParticleInsideWallIsRejected) {
  const std::string t = edit(kScene, "position_m = [0, 0.001, 0]", "position_m = [0, 0.0004, 0]");
  EXPECT_ERROR_NAMES(t, "[[particle]] #1 overlaps [[wall]] #1", "allow_initial_overlap");
  EXPECT_TRUE(error_of(edit(t, "dt_s = 1.0e-5", "dt_s = 1.0e-5\nallow_initial_overlap = true")).empty());
}

TEST(CaseParser, OverlappingExplicitParticlesAreRejected) {
  const std::string t = edit(kScene, "position_m = [0.002, 0.001, 0]", "position_m = [0.0009, 0.001, 0]");
  EXPECT_ERROR_NAMES(t, "[[particle]] #1 overlaps [[particle]] #2", "0.0001 m", "allow_initial_overlap");
  EXPECT_TRUE(error_of(edit(t, "dt_s = 1.0e-5", "dt_s = 1.0e-5\nallow_initial_overlap = true")).empty());
  // Touching exactly is not an overlap.
  EXPECT_TRUE(error_of(edit(kScene, "position_m = [0.002, 0.001, 0]", "position_m = [0.001, 0.001, 0]")).empty());
}

TEST(CaseParser, OverlapUsesClumpOrientation) {
  // Two-sphere clump along x, offsets +-0.6 mm, r = 0.5 mm; second particle 1.5 mm up the y axis.
  std::string t = edit(kScene, "kind = \"sphere\"\ndiameter_m = 1e-3",
                       "kind = \"clump\"\nspheres = [[-6e-4, 0, 0, 5e-4], [6e-4, 0, 0, 5e-4]]");
  t = edit(t, "position_m = [0, 0.001, 0]", "position_m = [0, 0.001, 0]\norientation = [1, 0, 0, 0]");
  t = edit(t, "position_m = [0.002, 0.001, 0]", "position_m = [0, 0.0025, 0]");
  EXPECT_TRUE(error_of(t).empty()) << error_of(t);
  // Turned by 90 degrees about z, the first clump points up into the second one (and into the floor).
  const std::string turned = edit(t, "orientation = [1, 0, 0, 0]", "orientation = [0.7071067811865476, 0, 0, 0.7071067811865476]");
  EXPECT_ERROR_NAMES(turned, "[[particle]] #1 overlaps");
}

TEST(CaseParser, NothingToSimulateIsRejected) {
  std::string t = kScene.substr(0, kScene.find("[[particle]]")) + "[[phase]]\nname = \"x\"\nsteps = 1\n";
  t = edit(t, "[[shape]]\nname = \"b\"\nkind = \"sphere\"\ndiameter_m = 1e-3\n", "");
  EXPECT_ERROR_NAMES(t, "nothing to simulate");
}

// Frames are cross-sections of the drum: asked for in a scene without one, they are an error
// (before, the run wrote an empty frames/ folder and said nothing).
TEST(CaseParser, FramesWithoutADrumAreRejected) {
  EXPECT_TRUE(error_of(kScene).empty()) << error_of(kScene);
  EXPECT_ERROR_NAMES(kScene + "\n[output]\nframe_every_s = 0.001\n", "[output].frame_every_s");
}

// Speed images too: asked for without a drum, an error; their keys' values are checked.
TEST(CaseParser, SpeedImageKeysAreChecked) {
  EXPECT_ERROR_NAMES(kScene + "\n[output]\nspeed_images = true\n", "[output].speed_images");
  EXPECT_TRUE(error_of(kScene + "\n[output]\nspeed_images = false\n").empty());
  EXPECT_ERROR_NAMES(kScene + "\n[output]\nspeed_images = 1\n", "speed_images");
  EXPECT_ERROR_NAMES(kScene + "\n[output]\nspeed_image_max_m_s = 0.0\n", "speed_image_max_m_s");
  EXPECT_ERROR_NAMES(kScene + "\n[output]\nspeed_image_max_m_s = -1.0\n", "speed_image_max_m_s");
  const auto c = case_file::parse_case(kScene + "\n[output]\nspeed_image_max_m_s = 0.02\n", "c").config;
  ASSERT_TRUE(c.output.speed_image_max_m_s);
  EXPECT_DOUBLE_EQ(*c.output.speed_image_max_m_s, 0.02);
  EXPECT_FALSE(c.output.speed_images);
  EXPECT_ERROR_NAMES(kScene + "\n[output]\nspeed_image_size_px = 100\n", "speed_image_size_px");
  EXPECT_ERROR_NAMES(kScene + "\n[output]\nspeed_image_every_s = 0.0\n", "speed_image_every_s");
  const auto lc = case_file::parse_case(kScene + "\n[output]\nspeed_image_every_s = 0.01\n", "c");  // no drum: unused
  ASSERT_EQ(lc.warnings.size(), 1u);
  EXPECT_NE(lc.warnings[0].find("[output].speed_image_every_s is not used"), std::string::npos) << lc.warnings[0];
}

// The top of the speed images' colour scale, one function for the run and its report: the larger
// of twice the rim speed and sqrt(g d) (1 mm beads, D = 100 mm).
TEST(CaseParser, SpeedImageScaleIsTheLargerOfTwiceTheRimSpeedAndTheFallOverOneDiameter) {
  auto scale = [](const std::string& text) { return case_file::speed_image_scale_m_s(case_file::parse_case(text, "c").config); };
  EXPECT_NEAR(scale(kSpecExample), std::sqrt(9.81 * 1e-3), 1e-12);  // 2 x rim = 5.2 mm/s at 0.5 rpm
  EXPECT_NEAR(scale(edit(kSpecExample, "rpm = 0.5", "rpm = 60.0")), 2.0 * 60.0 * 2.0 * M_PI / 60.0 * 0.05, 1e-12);
  EXPECT_NEAR(scale(edit(kSpecExample, "rpm = 0.5", "rpm = -60.0")), 2.0 * 2.0 * M_PI * 0.05, 1e-12);
  // (weak gravity: the fall over one diameter, 1 mm/s, under twice the rim speed)
  EXPECT_NEAR(scale(edit(kSpecExample, "gravity_m_s2 = [0.0, -9.81, 0.0]", "gravity_m_s2 = [0.0, -0.001, 0.0]")),
              2.0 * 0.5 * 2.0 * M_PI / 60.0 * 0.05, 1e-12);
  EXPECT_NEAR(scale(edit(kSpecExample, "trace = false", "trace = false\nspeed_image_max_m_s = 0.3")), 0.3, 0.0);
  EXPECT_EQ(case_file::speed_image_scale_m_s(case_file::parse_case(kScene, "c").config), 0.0);  // no drum
}

TEST(CaseParser, SyntaxErrorNamesFileAndLine) {
  EXPECT_ERROR_NAMES("[run]\ndt_s = = 1\n", "case.toml:2:");
}

TEST(CaseParser, MissingFileIsNamed) {
  try {
    case_file::load_case("/nonexistent/dir/case.toml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/case.toml"), std::string::npos);
  }
}

TEST(CaseParser, LoadCaseReadsFile) {
  const auto dir = std::filesystem::temp_directory_path() / ("biodem_case_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto path = (dir / "glass.toml").string();
  std::ofstream(path) << kSpecExample;
  const auto lc = case_file::load_case(path);
  EXPECT_EQ(lc.config.source_path, path);
  EXPECT_NE(lc.warnings.at(0).rfind(path, 0), std::string::npos);
  std::filesystem::remove_all(dir);
}

// ------------------------------------------------------------------ steps

// The one rounding of phase lengths, and times written as whole steps: 348,000 steps of 1e-5 s
// summed one at a time (as the engines' clocks) print as 3.48000000001 at 12 digits; written as
// whole steps they print 3.48.
TEST(Steps, PhaseStepsAndTimesOfWholeSteps) {
  EXPECT_EQ(config::steps_for(0.05, 1.5e-5), 3333u);  // 3333.3: rounded, not up
  EXPECT_EQ(config::steps_for(0.2, 1e-5), 20000u);
  double t = 0.0;
  for (int n = 0; n < 348000; ++n) t += 1e-5;
  char sum[64], whole[64];
  std::snprintf(sum, sizeof sum, "%.12g", t);
  std::snprintf(whole, sizeof whole, "%.12g", config::whole_steps_time(t, 1e-5));
  EXPECT_STRNE(sum, "3.48") << "the sum shows its rounding (else this test shows nothing)";
  EXPECT_STREQ(whole, "3.48");
  EXPECT_EQ(config::whole_steps_time(0.0, 1e-5), 0.0);
}

// ------------------------------------------------------------------ report

TEST(CaseReport, DescribesDerivedQuantities) {
  const auto c = case_file::parse_case(edit(kSpecExample, "count = 19791", "fill_fraction = 0.4"), "case.toml").config;
  const std::string r = output::describe_case(c);
  for (const char* part : {"Rayleigh time", "d_eq", "mass", "inertia", "count = ", "particles across the width",
                           "revolutions", "drum rotating", "sqrt(2 g D)", "% of the drum volume"})
    EXPECT_NE(r.find(part), std::string::npos) << part << "\n" << r;
}

// With a count, the report gives the fill fraction it implies (SPEC 11 asks for the converse),
// and that fill fraction gives the count back (within the rounding of its three digits).
TEST(CaseReport, CountGivesTheFillFractionThatGivesItBack) {
  const auto c = case_file::parse_case(kSpecExample, "case.toml").config;
  const std::string r = output::describe_case(c);
  const std::string key = "[insertion].fill_fraction = ";
  const std::size_t at = r.find(key);
  ASSERT_NE(at, std::string::npos) << r;
  const double fill = std::stod(r.substr(at + key.size()));
  EXPECT_NEAR(fill, 0.44, 0.005);  // 19,791 beads of 1 mm: 26.4 % of the drum's volume, over 0.6
  const auto f = case_file::parse_case(edit(kSpecExample, "count = 19791", "fill_fraction = " + std::to_string(fill)),
                                       "case.toml").config;
  EXPECT_NEAR(static_cast<double>(case_file::implied_particle_count(f)), 19791.0, 0.002 * 19791.0);
}

TEST(CaseReport, NeedleReportShowsSpheresAndLength) {
  std::string t = edit(kSpecExample, "kind = \"sphere\"\ndiameter_m = 1.0e-3",
                       "kind = \"needle\"\nd50_m = 746e-6\naspect_ratio = 0.38");
  t = edit(t, "coarse_grain = 1.0", "coarse_grain = 4.0");
  t = edit(t, "count = 19791", "count = 10");
  t = edit(t, "diameter_m = 0.100", "diameter_m = 0.400");
  t = edit(t, "width_m = 0.005", "width_m = 0.020");
  t = edit(t, "dt_s = 1.5e-5", "dt_s = 1e-5");
  const auto lc = case_file::parse_case(t, "case.toml");
  const std::string r = output::describe_case(lc.config);
  EXPECT_NE(r.find("n_spb = 3"), std::string::npos) << r;
  EXPECT_NE(r.find("clump length 0.007758"), std::string::npos) << r;  // 4 x 1940 um
  EXPECT_NEAR(case_file::resolved_skin_m(lc.config), 373e-6, 1e-12);   // an eighth of d = 4 x 746 um
}

// ------------------------------------------------------------------ output directory

TEST(OutputDir, CreatesNestedDirectoryAndWritesAtomically) {
  const auto base = std::filesystem::temp_directory_path() / ("biodem_out_test_" + std::to_string(::getpid()));
  const auto dir = base / "a" / "b";
  output::prepare_output_dir(dir.string());
  EXPECT_TRUE(std::filesystem::is_directory(dir));
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), std::filesystem::directory_iterator()), 0);
  const auto file = (dir / "x.txt").string();
  output::write_file_atomic(file, "one");
  output::write_file_atomic(file, "two");
  std::ifstream in(file);
  std::string s;
  in >> s;
  EXPECT_EQ(s, "two");
  EXPECT_FALSE(std::filesystem::exists(file + ".tmp"));
  std::filesystem::remove_all(base);
}

TEST(OutputDir, PathUnderRegularFileIsRejected) {
  const auto base = std::filesystem::temp_directory_path() / ("biodem_out_file_" + std::to_string(::getpid()));
  std::ofstream(base.string()) << "x";
  const std::string dir = (base / "sub").string();
  try {
    output::prepare_output_dir(dir);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("--out " + dir), std::string::npos) << msg;
    EXPECT_NE(msg.find("cannot create directory"), std::string::npos) << msg;
  }
  try {
    output::prepare_output_dir(base.string());
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("not a directory"), std::string::npos) << e.what();
  }
  EXPECT_THROW(output::write_file_atomic((base / "f").string(), "x"), Error);
  std::filesystem::remove(base);
}

TEST(CaseParser, WallKinds) {
  const std::string cyl = edit(kScene, "kind = \"plane\"\nmaterial = \"steel\"\npoint_m = [0, 0, 0]\nnormal = [0, 2, 0]",
                               "kind = \"cylinder\"\nmaterial = \"steel\"\npoint_m = [0, 0, -1]\naxis = [0, 0, 3]\n"
                               "radius_m = 0.05\nangular_velocity_rad_s = 0.1");
  const auto c = case_file::parse_case(cyl, "case.toml").config;
  EXPECT_EQ(c.walls[0].kind, config::WallKind::Cylinder);
  EXPECT_DOUBLE_EQ(c.walls[0].normal[2], 1.0);
  EXPECT_DOUBLE_EQ(c.walls[0].length_m, 0.0);
  EXPECT_DOUBLE_EQ(c.walls[0].angular_velocity_rad_s, 0.1);
  EXPECT_ERROR_NAMES(edit(cyl, "radius_m = 0.05", "radius_m = 0.0005"), "[[particle]] #1 overlaps [[wall]] #1");
  EXPECT_ERROR_NAMES(edit(cyl, "axis = [0, 0, 3]", "normal = [0, 0, 3]"), "[[wall]] #1 .normal", "cylinder");
  EXPECT_ERROR_NAMES(edit(kScene, "normal = [0, 2, 0]", "normal = [0, 0, 0]"), "[[wall]] #1 .normal", "non-zero");
  EXPECT_ERROR_NAMES(edit(kScene, "kind = \"plane\"", "kind = \"disc\""), "[[wall]] #1 .radius_m", "missing");
  EXPECT_ERROR_NAMES(edit(kScene, "kind = \"plane\"", "kind = \"sheet\""), "[[wall]] #1 .kind");
}

TEST(CaseParser, DomainRules) {
  const std::string t = kScene + "\n[domain]\nmin_m = [-0.01, 0, -0.01]\nmax_m = [0.01, 0.02, 0.01]\n"
                                 "periodic = [true, false, true]\n";
  const auto c = case_file::parse_case(t, "case.toml").config;
  ASSERT_TRUE(c.domain);
  EXPECT_TRUE(c.domain->periodic[0]);
  EXPECT_FALSE(c.domain->periodic[1]);
  EXPECT_ERROR_NAMES(edit(t, "max_m = [0.01, 0.02, 0.01]", "max_m = [0.01, 0.0, 0.01]"), "[domain].max_m");
  EXPECT_ERROR_NAMES(edit(t, "periodic = [true, false, true]", "periodic = [1, 0, 1]"), "[domain].periodic");
  EXPECT_ERROR_NAMES(edit(t, "max_m = [0.01, 0.02, 0.01]", "max_m = [-0.008, 0.02, 0.01]"), "[domain].max_m",
                     "periodic length along x");
  // Walls and sinks that depend on the position along a periodic axis are refused (positions are
  // not wrapped for wall tests: a bead crossing x = 5 mm fell through a periodic floor plate).
  const std::string plate = "\n[[wall]]\nkind = \"rectangle\"\nmaterial = \"steel\"\npoint_m = [0, -0.001, 0]\n"
                            "normal = [0, 1, 0]\nu = [1, 0, 0]\nsize_m = [0.01, 0.01]\n";
  EXPECT_ERROR_NAMES(t + plate, "[[wall]] #2 (rectangle)", "periodic along x");
  EXPECT_ERROR_NAMES(edit(t, "normal = [0, 2, 0]", "normal = [1, 2, 0]"), "[[wall]] #1 (plane)",
                     "perpendicular to x");
  EXPECT_ERROR_NAMES(t + "\n[[sink]]\nkind = \"outside_box\"\nmin_m = [-0.005, -0.01, -0.02]\nmax_m = [0.02, 0.03, 0.02]\n",
                     "[[sink]] #1 (outside_box)", "span the periodic cell");
  EXPECT_NO_THROW(case_file::parse_case(
      t + "\n[[sink]]\nkind = \"outside_box\"\nmin_m = [-0.02, -0.01, -0.02]\nmax_m = [0.02, 0.03, 0.02]\n", "case.toml"));
  // An explicit particle outside the box (along a non-periodic axis) is refused before any step.
  EXPECT_ERROR_NAMES(edit(t, "position_m = [0, 0.001, 0]", "position_m = [0, 0.03, 0]"), "[[particle]] #1.position_m",
                     "outside the [domain] box");
  EXPECT_NO_THROW(case_file::parse_case(edit(t, "position_m = [0, 0.001, 0]", "position_m = [0.015, 0.001, 0]"),
                                        "case.toml"));  // (x is periodic)
}

// The free-surface profile's bin width and wall zone (SPEC 6: configurable), in metres: positive,
// only with a drum, at most a fifth (bin) and half (wall zone) of the drum radius (the SPEC
// example's drum: R = 50 mm).
TEST(CaseParser, SurfaceProfileKeysAreChecked) {
  const auto c = case_file::parse_case(
                     edit(kSpecExample, "trace = false", "trace = false\nsurface_bin_m = 1.0e-3\nsurface_wall_zone_m = 4.0e-3"), "c")
                     .config;
  EXPECT_DOUBLE_EQ(*c.output.surface_bin_m, 1.0e-3);
  EXPECT_DOUBLE_EQ(*c.output.surface_wall_zone_m, 4.0e-3);
  EXPECT_FALSE(case_file::parse_case(kSpecExample, "c").config.output.surface_bin_m);
  EXPECT_ERROR_NAMES(edit(kSpecExample, "trace = false", "trace = false\nsurface_bin_m = 0.0"), "[output].surface_bin_m");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "trace = false", "trace = false\nsurface_wall_zone_m = -1e-3"),
                     "[output].surface_wall_zone_m");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "trace = false", "trace = false\nsurface_bin_m = 0.011"),
                     "[output].surface_bin_m = 0.011: at most 0.01 m");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "trace = false", "trace = false\nsurface_wall_zone_m = 0.026"),
                     "[output].surface_wall_zone_m = 0.026: at most 0.025 m");
  EXPECT_ERROR_NAMES(kScene + "\n[output]\nsurface_bin_m = 1e-3\n", "[output].surface_bin_m");
}

TEST(CaseParser, OutputRules) {
  EXPECT_ERROR_NAMES(edit(kSpecExample, "sample_hz = 50.0", "sample_hz = 0"), "[output].sample_hz");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "snapshot_every_s = 1.0", "snapshot_every_s = -1.0"),
                     "[output].snapshot_every_s");
  const auto c = case_file::parse_case(edit(kSpecExample, "trace = false", "trace = true\nframe_every_s = 0.02"), "c").config;
  EXPECT_TRUE(c.output.trace);
  EXPECT_EQ(c.output.frame_size_px, 512u);
  EXPECT_DOUBLE_EQ(*c.output.frame_every_s, 0.02);
}

TEST(CaseParser, DeviceAndWallRollingReference) {
  const auto def = case_file::parse_case(kSpecExample, "case.toml").config;
  EXPECT_EQ(def.run.device, config::Device::Cpu);
  EXPECT_EQ(def.contact.wall_rolling_reference, config::WallRollingReference::Wall);
  const auto gpu = case_file::parse_case(edit(kSpecExample, "[run]", "[run]\ndevice = \"gpu\""), "case.toml").config;
  EXPECT_EQ(gpu.run.device, config::Device::Gpu);
  const auto lab = case_file::parse_case(edit(kSpecExample, "[run]", "[contact]\nwall_rolling_reference = \"lab\"\n\n[run]"),
                                  "case.toml").config;
  EXPECT_EQ(lab.contact.wall_rolling_reference, config::WallRollingReference::Lab);
  // The friction rule defaults to the reference one (SPEC 2.2: cohesion kept out of the limits)
  // with or without a [contact] table, and follows the key.
  EXPECT_FALSE(def.contact.tangential_reduce);
  EXPECT_FALSE(lab.contact.tangential_reduce);
  const auto reduce = case_file::parse_case(edit(kSpecExample, "[run]", "[contact]\ntangential_reduce = true\n\n[run]"),
                                            "case.toml").config;
  EXPECT_TRUE(reduce.contact.tangential_reduce);
  EXPECT_EQ(reduce.contact.wall_rolling_reference, config::WallRollingReference::Wall);
  EXPECT_ERROR_NAMES(edit(kSpecExample, "[run]", "[run]\ndevice = \"tpu\""), "[run].device", "\"gpu\"");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "[run]", "[contact]\nwall_rolling_reference = \"world\"\n\n[run]"),
                     "[contact].wall_rolling_reference", "\"lab\"");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "[run]", "[contact]\nrolling_reference = \"lab\"\n\n[run]"),
                     "[contact].rolling_reference");
}

// Inputs the engine cannot honour, each a one-line error naming the key (before, each was
// accepted without a word): gravity along the drum's axis or along x (alpha is measured with y
// up: 90 degrees off, or meaningless), a sample period or an interval under half a step (written
// at every step instead), an aspect ratio giving millions of spheres per needle (hours of clump
// building, or an int overflow read as one sphere), a whole-number key written as a real, a rest
// cap in the bulk test that has no rest phase. An interval the step rounding moves by over 1 % is
// warned about with the one the run uses.
TEST(CaseParser, InputsTheEngineCannotHonourAreOneLineErrors) {
  const std::string g = "gravity_m_s2 = [0.0, -9.81, 0.0]";
  EXPECT_ERROR_NAMES(edit(kSpecExample, g, "gravity_m_s2 = [0.0, 0.0, -9.81]"), "[run].gravity_m_s2 = [0, 0, -9.81]",
                     "gravity must be [0, -g, 0]");
  EXPECT_ERROR_NAMES(edit(kSpecExample, g, "gravity_m_s2 = [-9.81, 0.0, 0.0]"), "[run].gravity_m_s2");
  EXPECT_ERROR_NAMES(edit(kSpecExample, g, "gravity_m_s2 = [0.0, 0.0, 0.0]"), "[run].gravity_m_s2");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "sample_hz = 50.0", "sample_hz = 1e6"), "[output].sample_hz = 1e+06",
                     "under half the time step dt = 1.5e-05 s");
  EXPECT_ERROR_NAMES(edit(kSpecExample, "snapshot_every_s = 1.0", "snapshot_every_s = 1e-9"),
                     "[output].snapshot_every_s = 1e-09");
  const auto rounded = case_file::parse_case(edit(kSpecExample, "sample_hz = 50.0", "sample_hz = 40000.0"), "case.toml");
  std::string all;
  for (const auto& w : rounded.warnings) all += w + "\n";
  EXPECT_NE(all.find("[output].sample_hz = 40000: outputs are written after whole steps, so every 2 steps"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("33333.3 Hz"), std::string::npos) << all;
  EXPECT_EQ(case_file::parse_case(kSpecExample, "case.toml").warnings.size(), 1u);  // (the time step's only)

  std::string needle = edit(kScene, "kind = \"sphere\"\ndiameter_m = 1e-3", "kind = \"needle\"\nd50_m = 746e-6\naspect_ratio = 5.8207636e-10");
  EXPECT_ERROR_NAMES(needle, ".aspect_ratio", "spheres per needle (SPEC 3); at most 1000");
  needle = edit(kScene, "kind = \"sphere\"\ndiameter_m = 1e-3",
                "kind = \"needle\"\nd50_m = 746e-6\naspect_ratio = 0.5\noverlap_factor = 0.9999");
  EXPECT_ERROR_NAMES(needle, ".aspect_ratio", "at most 1000");

  auto file = [](const char* name) {
    std::ifstream in(std::string(BIODEM_SOURCE_DIR) + "/tests/cases/" + name);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  const std::string heap = file("heap_tiny.toml"), bulk = file("bulk_density_tiny.toml");
  ASSERT_FALSE(heap.empty());
  EXPECT_ERROR_NAMES(edit(heap, "\n[heap]\n", "\n[heap]\nsectors = 6.0\n"), "[heap].sectors", "integer");
  EXPECT_EQ(case_file::parse_case(edit(heap, "\n[heap]\n", "\n[heap]\nsectors = 6\n"), "case.toml").config.bulk_test->sectors, 6u);
  EXPECT_ERROR_NAMES(edit(bulk, "\n[bulk_density]\n", "\n[bulk_density]\nmax_rest_s = 0.001\n"), "[bulk_density].max_rest_s",
                     "no rest phase");
}

// `check` (and run.log) give a coarse-grained particle also as measured: lengths / s, volume /
// s^3 (SPEC 8's table gives the particles before coarse graining). The 1 mm bead at x4: 4 mm in
// the engine, 1 mm and pi/6 mm^3 before.
TEST(CaseParser, ReportGivesACoarseGrainedParticleAlsoAsMeasured) {
  const std::string at4 = output::describe_case(
      case_file::parse_case(edit(edit(kSpecExample, "coarse_grain = 1.0", "coarse_grain = 4.0"), "count = 19791", "count = 200"),
                            "case.toml")
          .config);
  EXPECT_NE(at4.find("sphere, diameter 0.004 m"), std::string::npos) << at4;
  EXPECT_NE(at4.find("before coarse graining: volume 5.236e-10 m^3, d_eq 0.001 m"), std::string::npos) << at4;
  const std::string at1 = output::describe_case(case_file::parse_case(kSpecExample, "case.toml").config);
  EXPECT_EQ(at1.find("before coarse graining"), std::string::npos) << at1;
}
