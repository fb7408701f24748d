// Issue 4, verification 4: for a small simulated drum, alpha from the particles (mass-weighted,
// series.csv of `run`) and alpha from the back-lit frames rendered during the same run and read
// back by `biodem video` agree within 1 degree at every frame of the rotation phase.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "test_util.hpp"

using namespace biodem::testing;

TEST(FramesConsistency, AlphaFromParticlesAndFromRenderedFramesAgree) {
  const std::string out = fresh_dir("frames_run"), vid = fresh_dir("frames_video");
  std::filesystem::create_directories(out);
  // The smoke-test drum (1,781 beads, 30 mm x 5 mm, 20 rpm), rotated 0.04 rev, with frames every
  // 0.01 s and samples at the same instants.
  std::ifstream in(source_dir() + "/tests/cases/glass_smoke.toml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto edit = [&](const std::string& from, const std::string& to) {
    const auto at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
  };
  edit("sample_hz = 50.0", "sample_hz = 100.0\nframe_every_s = 0.01\nframe_size_px = 800");
  edit("revolutions = 0.12", "revolutions = 0.04");
  edit("trace = true", "trace = false");
  const std::string case_path = out + "_case.toml";
  std::ofstream(case_path) << text;

  auto r = run_command(biodem_exe() + " run " + case_path + " --out " + out + " --threads 1");
  ASSERT_EQ(r.status, 0) << r.output;
  // 0.01 s = 667 steps of 1.5e-5 s: frame k is taken at step 667 (k + 1).
  const double frame_dt = 667 * 1.5e-5;
  auto v = run_command(biodem_exe() + " video " + out + "/frames --fps " + std::to_string(1.0 / frame_dt) +
                       " --rpm 20 --quiet --out " + vid);
  ASSERT_EQ(v.status, 0) << v.output;

  auto sim = read_csv(out + "/series.csv");
  auto img = read_csv(vid + "/series.csv");
  const auto ts = to_numbers(sim["time_s"]), as = to_numbers(sim["alpha_deg"]), rev = to_numbers(sim["revolution"]);
  const auto tv = to_numbers(img["time_s"]), av = to_numbers(img["alpha_deg"]);
  ASSERT_GT(tv.size(), 5u);
  int matched = 0;
  double worst = 0.0;
  for (std::size_t k = 0; k < tv.size(); ++k) {
    const double t = tv[k] + frame_dt;  // video time starts at frame 0
    for (std::size_t i = 0; i < ts.size(); ++i)
      // Compared once the bed has formed (rotation phase): during insertion particles in flight
      // count by mass in one and by their shadow's area in the other.
      if (std::abs(ts[i] - t) < 1e-9 + 1e-6 * t && rev[i] > 0.0) {
        ASSERT_FALSE(std::isnan(av[k])) << "frame " << k;
        worst = std::max(worst, std::abs(as[i] - av[k]));
        EXPECT_NEAR(as[i], av[k], 1.0) << "t = " << ts[i];
        ++matched;
      }
  }
  EXPECT_GT(matched, 5);
  std::printf("[measured] %d frames matched, worst |alpha_particles - alpha_frames| = %.3f deg\n", matched, worst);
}
