// [[sink]] (issue 9): a body that falls into a sink is removed from the simulation and from
// every output from then on (trace, sphere and body snapshots), its mass is counted, the other
// bodies keep their ids, and a checkpoint taken after the removal resumes bit for bit.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <set>
#include <sstream>

#include "driver/build_simulation.hpp"
#include "case_file/case_parser.hpp"
#include "checkpoint/checkpoint.hpp"
#include "test_util.hpp"

using namespace biodem;
using namespace biodem::testing;
namespace fs = std::filesystem;

namespace {
const std::string kCase = source_dir() + "/tests/cases/sink_tiny.toml";
}

TEST(Sink, RemovedBodyIsGoneFromEveryOutput) {
  const std::string d = fresh_dir("sink_tiny");
  const auto r = run_command(biodem_exe() + " run " + kCase + " --out " + d + " --threads 1");
  ASSERT_EQ(r.status, 0) << r.output;

  // Trace: ids 0, 1, 2 at first; bead 1 is last seen before it crosses y = -5 mm, i.e. after a
  // free fall of 10 mm: t = sqrt(2 * 0.01 / 9.81) = 45.2 ms (one sample is 5 ms).
  const auto t = read_csv(d + "/trace.csv");
  ASSERT_FALSE(t.at("time_s").empty());
  std::map<double, std::set<int>> ids;
  double last_seen_1 = -1.0;
  for (std::size_t k = 0; k < t.at("time_s").size(); ++k) {
    const double time = std::stod(t.at("time_s")[k]);
    const int id = std::stoi(t.at("body_id")[k]);
    ids[time].insert(id);
    if (id == 1) last_seen_1 = time;
  }
  EXPECT_EQ(ids.begin()->second, (std::set<int>{0, 1, 2}));
  EXPECT_EQ(ids.rbegin()->second, (std::set<int>{0, 2}));
  const double t_fall = std::sqrt(2.0 * 0.01 / 9.81);
  std::printf("[measured] bead 1 last in the trace at %.4f s; free fall to the sink %.4f s\n", last_seen_1, t_fall);
  EXPECT_LE(last_seen_1, t_fall);
  EXPECT_GT(last_seen_1, t_fall - 0.0051);

  // run.log counts one body and its mass, rho 4/3 pi R^3 = 1.3352e-6 kg.
  std::ifstream log(d + "/run.log");
  const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  const auto at = text.find("sinks removed ");
  ASSERT_NE(at, std::string::npos) << text;
  std::istringstream in(text.substr(at + 14));
  int n = 0;
  std::string word;
  double mass = 0.0;
  in >> n >> word >> mass;
  const double m1 = 2550.0 * 4.0 / 3.0 * std::numbers::pi * std::pow(0.5e-3, 3);
  EXPECT_EQ(n, 1);
  EXPECT_NEAR(mass / m1, 1.0, 1e-5);

  // snapshots/ holds the sphere files only (SPEC 11: one file per snapshot, one point per sphere);
  // the body files are in bodies/, one per snapshot as well.
  std::size_t n_spheres = 0, n_bodies = 0;
  for (const auto& e : fs::directory_iterator(d + "/snapshots")) {
    EXPECT_EQ(e.path().filename().string().rfind("spheres_", 0), 0u) << e.path();
    ++n_spheres;
  }
  for (const auto& e : fs::directory_iterator(d + "/bodies")) {
    EXPECT_EQ(e.path().filename().string().rfind("bodies_", 0), 0u) << e.path();
    ++n_bodies;
  }
  EXPECT_GE(n_spheres, 2u);
  EXPECT_EQ(n_spheres, n_bodies);

  // Last snapshots (spheres and bodies): two points, body ids 0 and 2, read with VTK's reader.
  const std::string py =
      "import vtk,sys,glob\n"
      "for pat in ('snapshots/spheres_','bodies/bodies_'):\n"
      "  f=sorted(glob.glob(sys.argv[1]+'/'+pat+'*.vtu'))[-1]\n"
      "  r=vtk.vtkXMLUnstructuredGridReader(); r.SetFileName(f); r.Update(); a=r.GetOutput().GetPointData().GetArray('body_id')\n"
      "  print(pat, sorted(int(a.GetTuple1(i)) for i in range(a.GetNumberOfTuples())))\n";
  const auto v = run_command(std::string(BIODEM_SYSTEM_PYTHON) + " -c \"" + py + "\" " + d);
  ASSERT_EQ(v.status, 0) << v.output;
  EXPECT_NE(v.output.find("snapshots/spheres_ [0, 2]"), std::string::npos) << v.output;
  EXPECT_NE(v.output.find("bodies/bodies_ [0, 2]"), std::string::npos) << v.output;
}

// In process: run to 0.06 s (after the removal), checkpoint, load into a fresh simulation of the
// same case, continue to 0.1 s, and compare with an uninterrupted run bit for bit.
TEST(Sink, CheckpointAfterRemovalResumesBitForBit) {
  const auto loaded = case_file::load_case(kCase);
  auto a = driver::build_simulation(loaded.config);
  auto b = driver::build_simulation(loaded.config);
  const std::uint64_t n_half = 4000, n_all = 6667;  // 0.06 s and 0.1 s at 1.5e-5 s
  a.sim->run_steps(n_all);
  b.sim->run_steps(n_half);
  ASSERT_EQ(b.sim->removed_bodies(), 1u);
  const std::string path = fresh_dir("sink_ckpt") + ".bin";
  checkpoint::save_checkpoint(path, *b.sim, {});
  auto c = driver::build_simulation(loaded.config);
  checkpoint::load_checkpoint(path, *c.sim);
  c.sim->run_steps(n_all - n_half);
  ASSERT_EQ(c.sim->bodies().size(), 2u);
  EXPECT_EQ(c.sim->removed_bodies(), 1u);
  EXPECT_EQ(c.sim->removed_mass_kg(), a.sim->removed_mass_kg());
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(c.sim->bodies().id[k], a.sim->bodies().id[k]);
    EXPECT_EQ(c.sim->bodies().position_m[k].y, a.sim->bodies().position_m[k].y);
    EXPECT_EQ(c.sim->bodies().velocity_m_s[k].y, a.sim->bodies().velocity_m_s[k].y);
  }
}

// Stable ids stay unique when bodies are added after a removal (a later insertion wave after a
// sink or a lost body removed some): the next body gets the count of bodies ever added, not the
// current count (before 2026-11-28 the third body below was given id 2, the id of the body kept).
// A checkpoint carries the removed count, so a resumed run numbers the same.
TEST(Sink, BodiesAddedAfterARemovalGetIdsNotGivenBefore) {
  const auto loaded = case_file::load_case(kCase);
  auto a = driver::build_simulation(loaded.config);
  sim::Simulation& s = *a.sim;
  ASSERT_EQ(s.bodies().size(), 3u);
  ASSERT_EQ(s.remove_bodies({0, 1, 0}), 1u);
  sim::BodyInit in;
  in.position_m = {0.0, 0.0, 0.0};
  s.add_body(in);
  EXPECT_EQ(s.bodies().id, (std::vector<std::uint32_t>{0, 2, 3}));
  const std::string path = fresh_dir("sink_ids") + ".bin";
  checkpoint::save_checkpoint(path, s, {});
  auto b = driver::build_simulation(loaded.config);
  checkpoint::load_checkpoint(path, *b.sim);
  ASSERT_EQ(b.sim->remove_bodies({1, 0, 0}), 1u);
  b.sim->add_body(in);
  s.remove_bodies({1, 0, 0});
  s.add_body(in);
  EXPECT_EQ(b.sim->bodies().id, (std::vector<std::uint32_t>{2, 3, 4}));
  EXPECT_EQ(b.sim->bodies().id, s.bodies().id);
}
