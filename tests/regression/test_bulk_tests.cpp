// Bulk-test scenarios (issue 9, SPEC 7): physics trends with stated tolerances on small scenes
// (1500 beads, ~10 s each on one core). Each run writes DIR/responses.csv (response,value,unit).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>

#include "test_util.hpp"

using namespace biodem::testing;
namespace fs = std::filesystem;

namespace {


/// Runs `case_file` with the given text replacements; returns the responses by name.
std::map<std::string, double> run_bulk(const std::string& case_file, const std::string& tag,
                                       const std::vector<std::pair<std::string, std::string>>& edits,
                                       const std::string& device = "cpu", const std::string& env = "") {
  std::string text = slurp(source_dir() + "/tests/cases/" + case_file);
  for (const auto& [from, to] : edits) {
    std::size_t at = 0, n = 0;
    while ((at = text.find(from, at)) != std::string::npos) {
      text.replace(at, from.size(), to);
      at += to.size();
      ++n;
    }
    if (n == 0) ADD_FAILURE() << "edit not applied: " << from;
  }
  const std::string d = fresh_dir("bulk_" + tag);
  fs::create_directories(d);
  { std::ofstream(d + "/case.toml") << text; }
  const auto r = run_command(env + biodem_exe() + " run " + d + "/case.toml --out " + d + "/out --threads 1 --device " + device);
  EXPECT_EQ(r.status, 0) << r.output;
  std::map<std::string, double> out;
  const auto c = read_csv(d + "/out/responses.csv");
  if (!c.count("response")) return out;
  for (std::size_t k = 0; k < c.at("response").size(); ++k) out[c.at("response")[k]] = std::stod(c.at("value")[k]);
  std::printf("[measured] %s:", tag.c_str());
  for (const auto& [k, v] : out) std::printf(" %s=%.4g", k.c_str(), v);
  std::printf("\n");
  return out;
}

std::vector<std::pair<std::string, std::string>> friction(const std::string& mu, const std::string& mu_r) {
  return {{"sliding_friction = 0.5", "sliding_friction = " + mu}, {"rolling_friction = 0.2", "rolling_friction = " + mu_r}};
}

}  // namespace

// Angle of repose rises with sliding friction (mu_r = 0.2): the mean of 8 sector fits (issue 20)
// is 8.5 +- 3.9 deg at mu_s = 0.8; at 0.2 the beads leave a bed 2-3 beads high whose sector fits
// lie between -4.0 and +2.3 deg (mean below 0): no heap, angle 0 (a mean sector angle that is not
// positive is no heap; before, -2.1 deg was reported as an angle of repose). With the single
// all-azimuth profile of before issue 20: 9.9 and 24.3 deg. Required: at least 4 deg higher.
TEST(BulkTests, AngleOfReposeRisesWithSlidingFriction) {
  auto lo = run_bulk("heap_tiny.toml", "heap_mu02", friction("0.2", "0.2"));
  auto hi = run_bulk("heap_tiny.toml", "heap_mu08", friction("0.8", "0.2"));
  EXPECT_EQ(lo["heap_found"], 0.0);
  EXPECT_EQ(lo["angle_of_repose_deg"], 0.0);
  EXPECT_LT(lo["angle_of_repose_min_deg"], 0.0);  // the bed's sector fits, kept for diagnosis
  ASSERT_EQ(hi["heap_found"], 1.0);
  EXPECT_EQ(lo["at_rest"], 1.0);
  EXPECT_EQ(hi["at_rest"], 1.0);
  EXPECT_GT(hi["angle_of_repose_deg"], lo["angle_of_repose_deg"] + 4.0);
  EXPECT_GT(hi["heap_height_m"], lo["heap_height_m"]);
  // This heap of 2 mm beads stands under 10 bead sizes high (9.4 mm): run.log says its angle
  // depends on single particles; nothing is held up by the cylinder.
  ASSERT_LT(hi["heap_height_m"], 10.0 * 2e-3);
  EXPECT_EQ(hi["lifted_bodies"], 0.0);
  const std::string log = slurp((fs::current_path() / "out_bulk_heap_mu08" / "out" / "run.log").string());
  EXPECT_NE(log.find("WARNING: heap: it stands "), std::string::npos) << log;
  EXPECT_NE(log.find(" particle sizes high (d_eq 2 mm): under 10"), std::string::npos) << log;
  EXPECT_EQ(log.find("held up by the lifted cylinder"), std::string::npos) << log;
}

// ... and with rolling friction (mu_s = 0.5): no heap at mu_r = 0.05 (a bed whose sector fits lie
// between -4.7 and +1.9 deg; -2.3 deg was reported before), 17.5 +- 5.8 deg at 0.5 (all-azimuth
// profile of before: 10.1 and 33.2).
TEST(BulkTests, AngleOfReposeRisesWithRollingFriction) {
  auto lo = run_bulk("heap_tiny.toml", "heap_mur005", friction("0.5", "0.05"));
  auto hi = run_bulk("heap_tiny.toml", "heap_mur05", friction("0.5", "0.5"));
  ASSERT_EQ(hi["heap_found"], 1.0);
  EXPECT_GT(hi["angle_of_repose_deg"], lo["angle_of_repose_deg"] + 4.0);
}

// Frictionless spheres (mu_s = mu_r = 0) leave no heap: nothing stands two diameters high.
TEST(BulkTests, FrictionlessSpheresLeaveNoHeap) {
  auto r = run_bulk("heap_tiny.toml", "heap_frictionless",
                    {{"sliding_friction = 0.5", "sliding_friction = 0.0"},
                     {"rolling_friction = 0.2", "rolling_friction = 0.0"},
                     {"max_rest_s = 1.0", "max_rest_s = 0.3"}});
  EXPECT_EQ(r["heap_found"], 0.0);
  EXPECT_EQ(r["angle_of_repose_deg"], 0.0);
  EXPECT_LT(r["heap_height_m"], 2.0 * 2.0e-3);
}

// Poured monodisperse spheres (mu_s = 0.5, mu_r = 0.2) in a container 10 diameters wide: the solid
// fraction of the core (one diameter away from wall, bottom and rim) lies in the random-loose
// range 0.53-0.60 (Song, Wang & Makse, Nature 453 (2008) 629: 0.536 in the limit of infinite
// friction; Onoda & Liniger 1990: 0.555 at vanishing gravity; Scott 1960: ~0.60 for spheres
// poured loosely). The core holds only ~100 spheres, so the insertion's random draws move it by
// about +-0.02: measured 0.5625, and 0.5456 after insertion switched to its own shuffle
// (src/core/random.hpp). The whole container is looser (wall layers) and bulk density = solid
// fraction x 2500 kg/m3 exactly.
TEST(BulkTests, PouredSpheresAreRandomLoose) {
  auto r = run_bulk("bulk_density_tiny.toml", "bulk_density", {});
  EXPECT_EQ(r["at_rest"], 1.0);
  EXPECT_GE(r["core_solid_fraction"], 0.53);
  EXPECT_LE(r["core_solid_fraction"], 0.60);
  EXPECT_LT(r["solid_fraction"], r["core_solid_fraction"]);
  EXPECT_NEAR(r["bulk_density_kg_m3"], 2500.0 * r["solid_fraction"], 1e-6 * r["bulk_density_kg_m3"]);
  // And the density is the retained mass over the container's volume (D = H = 20 mm in the case),
  // written out here: a radius taken for the diameter would give a quarter of it.
  const double container_m3 = 3.14159265358979 * 0.01 * 0.01 * 0.02;
  EXPECT_NEAR(r["bulk_density_kg_m3"], r["mass_in_container_kg"] / container_m3, 1e-6 * r["bulk_density_kg_m3"]);
  EXPECT_GT(r["solid_fraction"], 0.45);
}

// Shear box: the retainment ratio rises with cohesion, CED 0 -> 200 kJ/m3: measured 0.657 ->
// 0.999; required: at least +0.1.
TEST(BulkTests, RetainmentRisesWithCohesion) {
  auto ced = [](const std::string& v) {
    return std::vector<std::pair<std::string, std::string>>{
        {"rolling_friction = 0.2", "rolling_friction = 0.2\ncohesion_energy_density_j_m3 = " + v}};
  };
  auto lo = run_bulk("shear_box_tiny.toml", "shear_ced0", ced("0.0"));
  auto hi = run_bulk("shear_box_tiny.toml", "shear_ced200k", ced("2.0e5"));
  EXPECT_EQ(lo["at_rest"], 1.0);
  EXPECT_GT(lo["retainment_ratio"], 0.0);
  EXPECT_LT(lo["retainment_ratio"], 1.0);
  EXPECT_GT(hi["retainment_ratio"], lo["retainment_ratio"] + 0.1);
  EXPECT_NEAR(lo["mass_poured_kg"], 700 * 2500.0 * 4.0 / 3.0 * 3.14159265358979 * 1e-9, 1e-9);
}

// A bulk test on the GPU engine (its kernels on CPU threads): the shear box's gate is a
// translating wall and the beads that flow out fall into a sink. Measured: retainment 0.6686
// (CPU engine) and 0.6629 (GPU engine), 232 and 236 beads removed; the two differ as runs whose
// contact sums are added in another order do. A gate that did not rise keeps every bead
// (retainment 1); sinks that removed nothing would leave 0 in run.log. The GPU run times its
// kernel sets as on a GPU (BIODEM_GPU_FORCES=timed; the same bits whatever the set): the choice
// made stays across the removals' uploads (5 choices in the run since the insertion falls run
// in runs of steps, 4 before: the uploads of the insertion waves and the phase starts; 93 and 98
// when each removal timed the sets again).
TEST(BulkTests, ShearBoxOnTheGpuEngineAsOnTheCpuEngine) {
  const std::vector<std::pair<std::string, std::string>> none;  // the case as it is
  auto cpu = run_bulk("shear_box_tiny.toml", "shear_cpu", none);
  auto gpu = run_bulk("shear_box_tiny.toml", "shear_gpu", none, "gpu-emulated", "BIODEM_GPU_FORCES=timed ");
  EXPECT_EQ(gpu["at_rest"], 1.0);
  EXPECT_GT(cpu["retainment_ratio"], 0.5);
  EXPECT_LT(cpu["retainment_ratio"], 0.85);
  EXPECT_NEAR(gpu["retainment_ratio"], cpu["retainment_ratio"], 0.05);
  const std::string log = slurp((std::filesystem::current_path() / "out_bulk_shear_gpu" / "out" / "run.log").string());
  EXPECT_NE(log.find("engine: GPU engine"), std::string::npos);
  const auto at = log.find("sinks removed ");
  ASSERT_NE(at, std::string::npos);
  const int removed = std::stoi(log.substr(at + 14));
  std::printf("[measured] GPU engine's sink removed %d beads\n", removed);
  EXPECT_GT(removed, 150);
  EXPECT_LT(removed, 350);
  const auto tests_at = log.find("GPU removal tests (sinks, lost bodies; every 10th step): ");
  ASSERT_NE(tests_at, std::string::npos) << log;
  const auto ch = log.find(" choice(s) in the run");
  ASSERT_NE(ch, std::string::npos) << log;
  const int choices = std::stoi(log.substr(log.rfind('(', ch) + 1));
  std::printf("[measured] kernel-set choices in the GPU run: %d\n", choices);
  EXPECT_LE(choices, 8);
}

// The shipped raw-biomass bulk tests (cases/calibration, base merged in) are valid cases.
TEST(BulkTests, ShippedRawBiomassTestsAreValid) {
  const std::string dir = source_dir() + "/cases/calibration/";
  for (const char* t : {"heap_raw.toml", "bulk_density_raw.toml", "shear_box_raw.toml"}) {
    const std::string d = fresh_dir(std::string("raw_check_") + t);
    fs::create_directories(d);
    { std::ofstream(d + "/case.toml") << slurp(dir + "base_raw.toml") << "\n" << slurp(dir + t); }
    const auto r = run_command(biodem_exe() + " check " + d + "/case.toml");
    EXPECT_EQ(r.status, 0) << t << ": " << r.output;
  }
}

// A fill that reaches its time cap before the bed is at rest is a WARNING line of run.log (which
// a calibration campaign repeats), although responses.csv's at_rest speaks of the last phase
// only: before, the gate of this shear box opened on a moving bed without a word (retainment
// 0.653 against 0.669 settled).
TEST(BulkTests, AFillCutByItsCapIsWarnedAbout) {
  const auto r = run_bulk("shear_box_tiny.toml", "shortfill", {{"max_fill_s = 1.0", "max_fill_s = 0.03"}});
  EXPECT_TRUE(r.count("retainment_ratio"));
  const std::string log = slurp(fs::current_path().string() + "/out_bulk_shortfill/out/run.log");
  EXPECT_NE(log.find("WARNING: phase 'fill' reached its time cap before the bed was at rest"), std::string::npos) << log;
}
