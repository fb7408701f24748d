// The shipped biomass cases (SPEC 8, 9): every case in cases/ passes `biodem check`, and the
// needle clumps it derives are the paper's (n_spb, length, volume, d_eq, mass after coarse
// graining x4; particles across the drum width; dt against the Rayleigh time). Quick versions of
// the drum cases (tests/cases/biomass_*_quick.toml: a few hundred clumps in a 60 mm drum) run
// through insertion, the settle criterion and a little rotation without losing a particle.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <numbers>
#include <optional>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "test_util.hpp"

using namespace biodem::testing;

namespace {

constexpr double kScale = 4.0;       // coarse graining of the shipped biomass cases
constexpr double kDensity = 350.0;   // kg/m^3, all biomass samples (SPEC 8)
constexpr double kTableTol = 0.002;  // 0.2 %: SPEC 8's clump table vs the equations

std::string cases_dir() { return source_dir() + "/cases"; }

CommandResult check(const std::string& file) { return run_command(biodem_exe() + " check " + file); }

struct Needle {
  int n_spb = 0;
  double sphere_d_m = 0, length_m = 0, volume_m3 = 0, d_eq_m = 0, mass_kg = 0;
};

/// The needle block of `biodem check` for shape `name`.
std::optional<Needle> find_needle(const std::string& out, const std::string& name) {
  const std::regex re("  " + name +
                      R"(: needle, n_spb = (\d+) spheres of diameter (\S+) m, clump length (\S+) m[^\n]*\n)"
                      R"(\s+volume (\S+) m\^3, d_eq (\S+) m[^\n]*\n\s+as \w+: mass (\S+) kg)");
  std::smatch m;
  if (!std::regex_search(out, m, re)) return std::nullopt;
  return Needle{std::stoi(m[1]), std::stod(m[2]), std::stod(m[3]), std::stod(m[4]), std::stod(m[5]), std::stod(m[6])};
}

struct Sphere {
  double d_m = 0, volume_m3 = 0, d_eq_m = 0, mass_kg = 0;
};

std::optional<Sphere> find_sphere(const std::string& out, const std::string& name) {
  const std::regex re("  " + name +
                      R"(: sphere, diameter (\S+) m \(n_spb = 1, clump length (\S+) m\)\n\s+volume (\S+) m\^3, d_eq (\S+) m[^\n]*\n\s+as \w+: mass (\S+) kg)");
  std::smatch m;
  if (!std::regex_search(out, m, re)) return std::nullopt;
  EXPECT_EQ(m[1], m[2]) << "a sphere's clump length is its diameter";
  return Sphere{std::stod(m[1]), std::stod(m[3]), std::stod(m[4]), std::stod(m[5])};
}

/// First number after `label` in the output (NaN if absent).
double number_after(const std::string& out, const std::string& label) {
  const auto p = out.find(label);
  if (p == std::string::npos) return std::nan("");
  return std::stod(out.substr(p + label.size()));
}

/// "time step: dt = 1e-05 s = 14.6 % of the smallest Rayleigh time ..." -> 14.6
double dt_percent(const std::string& out) {
  const auto p = out.find("time step: dt = ");
  if (p == std::string::npos) return std::nan("");
  return number_after(out.substr(p, out.find('\n', p) - p), " s = ");
}

double across_width(const std::string& out) { return number_after(out, "particles across the width (width / d_eq): "); }

#define EXPECT_REL(actual, expected, tol) EXPECT_NEAR((actual) / (expected), 1.0, (tol)) << #actual

/// The needle equations of SPEC 3 (for the 9.6 % sample, whose published column is off them).
Needle needle_equations(double d, double a50, double c) {
  Needle n;
  n.n_spb = static_cast<int>(std::lround((1.0 / a50 - c) / (1.0 - c)));
  const double k = n.n_spb;
  n.sphere_d_m = d;
  n.length_m = k * (d - c * d) + c * d;
  n.volume_m3 = k * std::numbers::pi * std::pow(d / 2.0, 3) * (4.0 / 3.0 - (k - 1.0) / (12.0 * k) * (6.0 - 2.0 * c) * (4.0 * c * c));
  n.d_eq_m = std::cbrt(6.0 * n.volume_m3 / std::numbers::pi);
  n.mass_kg = kDensity * n.volume_m3;
  return n;
}

}  // namespace

TEST(BiomassCases, EveryShippedCasePassesCheck) {
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::directory_iterator(cases_dir()))
    if (e.path().extension() == ".toml") files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  ASSERT_GE(files.size(), 11u);  // 2 glass + 9 biomass
  for (const auto& f : files) {
    const auto r = check(f);
    EXPECT_EQ(r.status, 0) << f << "\n" << r.output;
    EXPECT_NE(r.output.find("time step: dt = "), std::string::npos) << f;
    // Only the expected warnings: dt between 20 and 40 % of T_R, and the unused shape of the
    // shape/cohesion variants (both shapes stay defined so that a variant is a one-line change).
    std::size_t p = 0;
    while ((p = r.output.find("warning: ", p)) != std::string::npos) {
      const std::string line = r.output.substr(p, r.output.find('\n', p) - p);
      EXPECT_TRUE(line.find("above the recommended 20 %") != std::string::npos ||
                  (f.find("raw_variant_") != std::string::npos && line.find("is not used") != std::string::npos))
          << f << ": " << line;
      ++p;
    }
  }
}

TEST(BiomassCases, RawNeedlesMatchThePaper) {
  const auto r = check(cases_dir() + "/raw_biomass_drum.toml");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto n = find_needle(r.output, "raw_needle");
  ASSERT_TRUE(n) << r.output;
  // SPEC 8 clump table (unscaled): n_spb 3, l 1940 um, V 0.6282 mm^3, d_eq 1062 um.
  EXPECT_EQ(n->n_spb, 3);
  EXPECT_REL(n->sphere_d_m, kScale * 746e-6, 1e-3);
  EXPECT_REL(n->length_m, kScale * 1940e-6, kTableTol);
  EXPECT_REL(n->volume_m3, std::pow(kScale, 3) * 0.6282e-9, kTableTol);
  EXPECT_REL(n->d_eq_m, kScale * 1062e-6, kTableTol);
  EXPECT_REL(n->mass_kg, kDensity * std::pow(kScale, 3) * 0.6282e-9, kTableTol);
  EXPECT_NEAR(across_width(r.output), 4.7, 0.05);  // SPEC 8: 4.7
  EXPECT_NE(r.output.find("count = 13122"), std::string::npos);
  EXPECT_NEAR(dt_percent(r.output), 14.6, 0.1);    // dt = 1e-5 s, T_R = 6.83e-5 s: no warning
  EXPECT_EQ(r.output.find("warning: "), std::string::npos) << r.output;
  // The paper's count fills 21.1 % of the drum with solid: 35 % of the drum at a sphere packing's
  // 0.6, 46.6 % at the needles' own 0.45 (check says both: the paper's fill is 40 %).
  EXPECT_NE(r.output.find("a fill fraction of 35 % at bulk solid fraction 0.6"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("at a bulk solid fraction of 0.45 (poured raw needles) the fill fraction is 46.6 %"),
            std::string::npos)
      << r.output;
}

TEST(BiomassCases, IntensivelyTorrefiedNeedlesMatchThePaper) {
  const auto r = check(cases_dir() + "/torrefied_24_5_drum.toml");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto n = find_needle(r.output, "ml24_5_needle");
  ASSERT_TRUE(n) << r.output;
  // SPEC 8: n_spb 3, l 1367 um, V 0.2199 mm^3, d_eq 748 um.
  EXPECT_EQ(n->n_spb, 3);
  EXPECT_REL(n->sphere_d_m, kScale * 526e-6, 1e-3);
  EXPECT_REL(n->length_m, kScale * 1367e-6, kTableTol);
  EXPECT_REL(n->volume_m3, std::pow(kScale, 3) * 0.2199e-9, kTableTol);
  EXPECT_REL(n->d_eq_m, kScale * 748e-6, kTableTol);
  EXPECT_REL(n->mass_kg, kDensity * std::pow(kScale, 3) * 0.2199e-9, kTableTol);
  EXPECT_NEAR(across_width(r.output), 6.7, 0.05);  // SPEC 8: 6.7
  EXPECT_NE(r.output.find("count = 24272"), std::string::npos);
  EXPECT_NEAR(dt_percent(r.output), 20.8, 0.1);    // the study's dt: warned, runs
  EXPECT_NE(r.output.find("above the recommended 20 %"), std::string::npos);
}

TEST(BiomassCases, MildlyTorrefiedNeedlesFollowTheEquations) {
  const auto r = check(cases_dir() + "/torrefied_9_6_drum.toml");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto n = find_needle(r.output, "ml9_6_needle");
  ASSERT_TRUE(n) << r.output;
  // From the equations with d50 = 667 um (SPEC 8): l = 2268 um, V = 0.5954 mm^3, d_eq = 1044 um.
  const Needle e = needle_equations(kScale * 667e-6, 0.31, 0.2);
  EXPECT_EQ(n->n_spb, 4);
  EXPECT_EQ(e.n_spb, 4);
  EXPECT_REL(n->sphere_d_m, e.sphere_d_m, 1e-3);
  EXPECT_REL(n->length_m, e.length_m, 1e-3);
  EXPECT_REL(n->volume_m3, e.volume_m3, 1e-3);
  EXPECT_REL(n->d_eq_m, e.d_eq_m, 1e-3);
  EXPECT_REL(n->mass_kg, e.mass_kg, 1e-3);
  EXPECT_REL(e.length_m, kScale * 2268e-6, kTableTol);
  EXPECT_REL(e.volume_m3, std::pow(kScale, 3) * 0.5954e-9, kTableTol);
  EXPECT_REL(e.d_eq_m, kScale * 1044e-6, kTableTol);
  // The paper's printed column (V = 0.5997 mm^3) is 0.7 % off its own equations.
  EXPECT_NEAR(std::pow(kScale, 3) * 0.5997e-9 / n->volume_m3 - 1.0, 0.007, 0.001);
  EXPECT_NEAR(across_width(r.output), 4.8, 0.05);  // SPEC 8: 4.8
  EXPECT_NE(r.output.find("count = 8572"), std::string::npos);
  EXPECT_NEAR(dt_percent(r.output), 24.6, 0.1);    // dt = 1.5e-5 s: warned, runs
  EXPECT_NE(r.output.find("above the recommended 20 %"), std::string::npos);
}

TEST(BiomassCases, PolydisperseRawMixesThreeNeedles) {
  const auto r = check(cases_dir() + "/raw_biomass_polydisperse_drum.toml");
  ASSERT_EQ(r.status, 0) << r.output;
  const std::pair<const char*, double> shapes[] = {
      {"raw_needle_500", 500e-6}, {"raw_needle_746", 746e-6}, {"raw_needle_890", 890e-6}};
  for (const auto& [name, d] : shapes) {
    const auto n = find_needle(r.output, name);
    ASSERT_TRUE(n) << name << "\n" << r.output;
    const Needle e = needle_equations(kScale * d, 0.38, 0.2);
    EXPECT_EQ(n->n_spb, 3) << name;
    EXPECT_REL(n->sphere_d_m, kScale * d, 1e-3);
    EXPECT_REL(n->volume_m3, e.volume_m3, 1e-3);
    EXPECT_REL(n->d_eq_m, e.d_eq_m, 1e-3);
  }
  EXPECT_NE(r.output.find("count = 19376"), std::string::npos);
  EXPECT_NE(r.output.find("volume fraction 0.25"), std::string::npos);
  EXPECT_NE(r.output.find("volume fraction 0.5"), std::string::npos);
  // The smallest (2 mm scaled) spheres set the Rayleigh time: dt = 22 % of it (SPEC 8).
  EXPECT_NEAR(dt_percent(r.output), 21.8, 0.1);
}

// `check` gives n_spb and the clump length for every kind of shape (SPEC 11): a sphere (1, its
// diameter; find_sphere above) and a free-form clump: spheres of 1 mm and 0.5 mm diameter whose
// centres are 1.5 mm apart: n_spb = 2, length 1.5 + 0.5 + 0.25 = 2.25 mm.
TEST(BiomassCases, CheckGivesNSpbAndLengthOfAClump) {
  std::ifstream in(cases_dir() + "/glass_beads_small.toml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string from = "kind = \"sphere\"\ndiameter_m = 1.0e-3";
  ASSERT_NE(text.find(from), std::string::npos);
  text.replace(text.find(from), from.size(),
               "kind = \"clump\"\nspheres = [[0.0, 0.0, 0.0, 0.5e-3], [1.5e-3, 0.0, 0.0, 0.25e-3]]");
  const std::string dt = "dt_s = 1.5e-5";  // (the small sphere's Rayleigh time is half the bead's)
  ASSERT_NE(text.find(dt), std::string::npos);
  text.replace(text.find(dt), dt.size(), "dt_s = 5.0e-6");
  const std::string d = fresh_dir("check_clump");
  std::filesystem::create_directories(d);
  std::ofstream(d + "/case.toml") << text;
  const auto r = check(d + "/case.toml");
  ASSERT_EQ(r.status, 0) << r.output;
  std::smatch m;
  const std::string out = r.output;
  ASSERT_TRUE(std::regex_search(out, m, std::regex(R"(bead1mm: clump, n_spb = (\d+) spheres, diameters (\S+) to (\S+) m, clump length (\S+) m)")))
      << r.output;
  EXPECT_EQ(m[1], "2");
  EXPECT_REL(std::stod(m[2]), 0.5e-3, 1e-3);
  EXPECT_REL(std::stod(m[3]), 1.0e-3, 1e-3);
  EXPECT_REL(std::stod(m[4]), 2.25e-3, 1e-3);
}

TEST(BiomassCases, PeriodicRawDrumHasNoEndPlates) {
  const auto r = check(cases_dir() + "/raw_biomass_periodic_drum.toml");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("periodic along the axis"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("end plates glass"), std::string::npos);
  const auto n = find_needle(r.output, "raw_needle");
  ASSERT_TRUE(n);
  EXPECT_EQ(n->n_spb, 3);
  EXPECT_NE(r.output.find("count = 13122"), std::string::npos);
}

TEST(BiomassCases, ShapeCohesionVariantsDifferOnlyInShapeAndCohesion) {
  // SPEC 9: the spheres have the scaled raw clump's d_eq (4 x 1062 um = 4.25 mm), so equal counts
  // mean equal solid volumes.
  struct V {
    const char* file;
    bool spheres, cohesive;
  };
  const V variants[] = {{"raw_variant_spheres.toml", true, false},
                        {"raw_variant_spheres_cohesive.toml", true, true},
                        {"raw_variant_needles.toml", false, false},
                        {"raw_variant_needles_cohesive.toml", false, true}};
  for (const auto& v : variants) {
    const auto r = check(cases_dir() + "/" + v.file);
    ASSERT_EQ(r.status, 0) << v.file << "\n" << r.output;
    EXPECT_NE(r.output.find("count = 13122"), std::string::npos) << v.file;
    EXPECT_NE(r.output.find("population " + std::string(v.spheres ? "raw_sphere" : "raw_needle") + " / " +
                            (v.cohesive ? "raw:" : "raw_noncohesive:")),
              std::string::npos)
        << v.file << "\n" << r.output;
    double volume = 0.0, d_eq = 0.0;
    if (v.spheres) {
      const auto s = find_sphere(r.output, "raw_sphere");
      ASSERT_TRUE(s) << r.output;
      volume = s->volume_m3, d_eq = s->d_eq_m;
      EXPECT_REL(s->d_m, kScale * 1062e-6, kTableTol);
    } else {
      const auto n = find_needle(r.output, "raw_needle");
      ASSERT_TRUE(n) << r.output;
      EXPECT_EQ(n->n_spb, 3);
      volume = n->volume_m3, d_eq = n->d_eq_m;
    }
    EXPECT_REL(volume, std::pow(kScale, 3) * 0.6282e-9, kTableTol);
    EXPECT_REL(d_eq, kScale * 1062e-6, kTableTol);
  }
  // The four files are the same but for the two [[population]] lines marked VARIANT.
  auto lines = [](const std::string& path) {
    std::vector<std::string> out;
    std::ifstream in(path);
    std::string l;
    bool header = true;
    while (std::getline(in, l)) {
      if (header && l.rfind("#", 0) == 0) continue;  // the comment block differs (what it is)
      header = false;
      out.push_back(l);
    }
    return out;
  };
  const auto base = lines(cases_dir() + "/raw_variant_needles_cohesive.toml");
  for (const auto& v : variants) {
    const auto other = lines(cases_dir() + "/" + v.file);
    ASSERT_EQ(other.size(), base.size()) << v.file;
    int differ = 0;
    for (std::size_t i = 0; i < base.size(); ++i)
      if (other[i] != base[i]) {
        ++differ;
        EXPECT_NE(base[i].find("# VARIANT"), std::string::npos) << v.file << ": " << other[i];
      }
    EXPECT_EQ(differ, (v.spheres ? 1 : 0) + (v.cohesive ? 0 : 1)) << v.file;
  }
}

namespace {

struct QuickCase {
  const char* file;
  std::uint64_t count;
  bool periodic;
};

/// Runs a quick case and checks what every drum run must deliver.
void run_quick(const QuickCase& q) {
  constexpr double radius = 0.030, width = 0.020;  // every quick case: 60 mm x 20 mm drum
  const std::string name = std::filesystem::path(q.file).stem().string();
  const std::string out = fresh_dir(name);
  const auto r = run_command(biodem_exe() + " run " + source_dir() + "/tests/cases/" + q.file + " --out " + out +
                             " --threads 1");
  ASSERT_EQ(r.status, 0) << r.output;

  std::ifstream log_in(out + "/run.log");
  const std::string log((std::istreambuf_iterator<char>(log_in)), std::istreambuf_iterator<char>());
  EXPECT_NE(log.find("bodies: " + std::to_string(q.count) + ","), std::string::npos) << log;
  EXPECT_NE(log.find("settled: mean kinetic energy below threshold"), std::string::npos) << log;

  auto series = read_csv(out + "/series.csv");
  const auto t = to_numbers(series["time_s"]);
  const auto rev = to_numbers(series["revolution"]);
  const auto alpha = to_numbers(series["alpha_deg"]);
  ASSERT_GT(t.size(), 10u);
  EXPECT_NEAR(rev.back(), 0.02, 0.001);
  for (std::size_t i = 1; i < alpha.size(); ++i) {
    EXPECT_TRUE(std::isfinite(alpha[i])) << "t = " << t[i];
    EXPECT_GT(alpha[i], 60.0) << "t = " << t[i];
    EXPECT_LT(alpha[i], 150.0) << "t = " << t[i];
  }

  // No particle escapes: every traced body centre stays inside the drum, and every body is
  // there at the last sample.
  auto trace = read_csv(out + "/trace.csv");
  const auto tt = to_numbers(trace["time_s"]);
  const auto id = to_numbers(trace["body_id"]);
  const auto x = to_numbers(trace["x_m"]), y = to_numbers(trace["y_m"]), z = to_numbers(trace["z_m"]);
  ASSERT_FALSE(x.empty());
  std::set<long> last_ids;
  double worst_r = 0.0, zmin = 1.0, zmax = -1.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    ASSERT_TRUE(std::isfinite(x[i]) && std::isfinite(y[i]) && std::isfinite(z[i])) << "row " << i;
    worst_r = std::max(worst_r, std::hypot(x[i], y[i]));
    zmin = std::min(zmin, z[i]);
    zmax = std::max(zmax, z[i]);
    if (tt[i] == tt.back()) last_ids.insert(std::lround(id[i]));
  }
  EXPECT_LT(worst_r, radius);
  if (!q.periodic) {
    EXPECT_GT(zmin, 0.0);
    EXPECT_LT(zmax, width);
  }
  EXPECT_EQ(last_ids.size(), q.count);

  // VTK's own reader takes every sphere snapshot (snapshots/) and every body snapshot (bodies/),
  // with their SPEC 11 fields and point counts (run.log: "bodies: N, spheres: M").
  const auto at = log.find("bodies: " + std::to_string(q.count) + ", spheres: ");
  ASSERT_NE(at, std::string::npos) << log;
  const long spheres = std::stol(log.substr(log.find("spheres: ", at) + 9));
  EXPECT_GT(spheres, static_cast<long>(q.count));
  const auto v = run_command(std::string(BIODEM_SYSTEM_PYTHON) + " " + source_dir() + "/tests/scripts/check_vtk.py " +
                             out + " " + std::to_string(spheres) + " " + std::to_string(q.count));
  EXPECT_EQ(v.status, 0) << v.output;
}

}  // namespace

TEST(BiomassQuickRuns, Raw) { run_quick({"biomass_raw_quick.toml", 295, false}); }
TEST(BiomassQuickRuns, MildlyTorrefied) { run_quick({"biomass_9_6_quick.toml", 193, false}); }
TEST(BiomassQuickRuns, IntensivelyTorrefied) { run_quick({"biomass_24_5_quick.toml", 546, false}); }
TEST(BiomassQuickRuns, Polydisperse) { run_quick({"biomass_polydisperse_quick.toml", 436, false}); }
TEST(BiomassQuickRuns, PeriodicAxis) { run_quick({"biomass_periodic_quick.toml", 295, true}); }
