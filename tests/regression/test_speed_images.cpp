// The speed images of `run` (SPEC 6, "snapshots coloured by speed"; output/speed_image.hpp): one
// per snapshot, numbered as the snapshot, in drum runs by default; none with
// [output] speed_images = false; the bed drawn where it lies (its centroid angle from the image
// against series.csv's), in the colours of the run's scale.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <set>

#include "test_util.hpp"

using namespace biodem::testing;
namespace fs = std::filesystem;

namespace {

// The smoke-test drum (30 mm x 5 mm, 20 rpm) with 300 beads, a short settle and 0.02 rev.
std::string small_drum(const std::string& extra_output, const std::string& revolutions = "0.02") {
  std::ifstream in(source_dir() + "/tests/cases/glass_smoke.toml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto edit = [&](const std::string& from, const std::string& to) {
    const auto at = text.find(from);
    if (at == std::string::npos) throw std::runtime_error("glass_smoke.toml has no '" + from + "'");
    text.replace(at, from.size(), to);
  };
  edit("count = 1781", "count = 300");
  edit("steps = 8000", "steps = 3000");
  edit("revolutions = 0.12", "revolutions = " + revolutions);
  edit("snapshot_every_s = 0.2", "snapshot_every_s = 0.05" + extra_output);
  edit("trace = true", "trace = false");
  return text;
}

/// Runs the small drum with `extra_output` in [output] into a fresh folder; returns the folder.
std::string run_small_drum(const std::string& name, const std::string& extra_output,
                           const std::string& revolutions = "0.02") {
  const std::string out = fresh_dir(name);
  fs::create_directories(out);
  const std::string case_path = out + "_case.toml";
  std::ofstream(case_path) << small_drum(extra_output, revolutions);
  const auto r = run_command(biodem_exe() + " run " + case_path + " --out " + out + " --threads 1");
  EXPECT_EQ(r.status, 0) << r.output;
  std::ofstream(out + "_output.txt") << r.output;
  return out;
}

std::set<std::string> names_in(const std::string& dir, const std::string& ext) {
  std::set<std::string> out;
  if (!fs::exists(dir)) return out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ext) out.insert(e.path().stem().string());
  return out;
}

}  // namespace

TEST(SpeedImages, OnePerSnapshotInDrumRunsShowingTheBedWhereItLies) {
  // 0.1 rev at 20 rpm: the drum has turned 36 degrees, the bed is lifted on the rising side (+x)
  const std::string out = run_small_drum("speed_images_on", "\nspeed_image_size_px = 400", "0.1");
  EXPECT_NE(slurp(out + "_output.txt").find("speed_images/"), std::string::npos);  // the done: line

  const auto vtu = names_in(out + "/snapshots", ".vtu"), png = names_in(out + "/speed_images", ".png");
  ASSERT_GE(vtu.size(), 3u);
  std::set<std::string> expected;
  for (const auto& v : vtu) expected.insert("speed_" + v.substr(v.find('_') + 1));  // spheres_NNNNNN -> speed_NNNNNN
  EXPECT_EQ(png, expected);

  const cv::Mat img = cv::imread(out + "/speed_images/" + *png.rbegin() + ".png", cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 400 + 130);  // speed_image_size_px and the colour bar's band
  EXPECT_EQ(img.rows, 400 + 30);   // and the title's
  // The beads are the coloured pixels (neither grey nor white) of the drum's square; the centroid
  // angle of their area, 90 + atan2(x, -y) about the drum's centre (pixel 199.5, 30 + 199.5),
  // against the last row of series.csv (mass-weighted): a mirrored or flipped image is 30 or more
  // degrees off.
  double n = 0.0, sx = 0.0, sy = 0.0;
  for (int row = 30; row < img.rows; ++row)
    for (int col = 0; col < 400; ++col) {
      const auto p = img.at<cv::Vec3b>(row, col);
      if (p[0] == p[1] && p[1] == p[2]) continue;
      n += 1.0;
      sx += col - 199.5;
      sy += (30 + 199.5) - row;
    }
  ASSERT_GT(n, 2000.0);  // 300 beads of 1 mm in a 30 mm drum at 12.3 px/mm: about 115 px each
  const double alpha_image = 90.0 + std::atan2(sx / n, -sy / n) * 180.0 / M_PI;
  auto series = read_csv(out + "/series.csv");
  const double alpha_run = to_numbers(series["alpha_deg"]).back();
  EXPECT_GT(alpha_run, 100.0) << "the bed must be lifted for the comparison to see a mirror";
  EXPECT_NEAR(alpha_image, alpha_run, 3.0);
  const std::string log = slurp(out + "/run.log");
  EXPECT_NE(log.find("speed images at each snapshot (400 px, colour scale 0 to 0.09905 m/s)"), std::string::npos)
      << "sqrt(g d) of 1 mm beads, above twice the rim speed (62.8 mm/s)";
}

// Every moving bead above a scale of 1 nm/s takes the top colour: the run hands its scale to the
// image (a unit or factor error between the two would leave the beads in lower colours).
TEST(SpeedImages, BeadsFasterThanTheScaleTakeItsTopColour) {
  const std::string out = run_small_drum("speed_images_top", "\nspeed_image_max_m_s = 1e-9");
  const auto png = names_in(out + "/speed_images", ".png");
  ASSERT_FALSE(png.empty());
  const cv::Mat img = cv::imread(out + "/speed_images/" + *png.rbegin() + ".png", cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  const cv::Vec3b top(37, 231, 253);  // viridis at 1 (blue, green, red)
  int coloured = 0, at_top = 0;
  for (int row = 30; row < img.rows; ++row)
    for (int col = 0; col < 512; ++col) {
      const auto p = img.at<cv::Vec3b>(row, col);
      if (p[0] == p[1] && p[1] == p[2]) continue;
      ++coloured;
      at_top += p == top;
    }
  ASSERT_GT(coloured, 2000);
  EXPECT_GT(at_top, 0.8 * coloured) << "(the rest: the discs' anti-aliased edges)";
}

// With a cadence of their own (as the frames: image k after step (k + 1) n, n = round(0.01 s / dt)
// = 667), not at the snapshots.
TEST(SpeedImages, AtTheirOwnCadenceWhenGivenOne) {
  const std::string out = run_small_drum("speed_images_every", "\nspeed_image_every_s = 0.01");
  const std::string said = slurp(out + "_output.txt");
  const auto at = said.find("done: ");
  ASSERT_NE(at, std::string::npos) << said;
  const std::uint64_t steps = std::stoull(said.substr(at + 6));
  ASSERT_GT(steps, 6000u);
  std::set<std::string> expected;
  char name[32];
  for (std::uint64_t k = 0; (k + 1) * 667 <= steps; ++k) {
    std::snprintf(name, sizeof name, "speed_%06llu", static_cast<unsigned long long>(k));
    expected.insert(name);
  }
  EXPECT_EQ(names_in(out + "/speed_images", ".png"), expected);
  EXPECT_GT(expected.size(), names_in(out + "/snapshots", ".vtu").size());
  EXPECT_NE(slurp(out + "/run.log").find("speed images every 0.01 s"), std::string::npos);
}

TEST(SpeedImages, NoneWhenSwitchedOffAndTheScaleKeyThenWarned) {
  const std::string out = run_small_drum("speed_images_off", "\nspeed_images = false\nspeed_image_max_m_s = 0.5");
  EXPECT_FALSE(fs::exists(out + "/speed_images"));
  EXPECT_GE(names_in(out + "/snapshots", ".vtu").size(), 3u);
  EXPECT_NE(slurp(out + "_output.txt").find("[output].speed_image_max_m_s is not used"), std::string::npos);
}
