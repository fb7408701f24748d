// The speed images of `run` (SPEC 6, "snapshots coloured by speed"; output/speed_image.hpp): one
// per snapshot, numbered as the snapshot, in drum runs by default; none with
// [output] speed_images = false; the bed drawn where it lies (the lower half of the drum).
#include <gtest/gtest.h>

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
std::string small_drum(const std::string& extra_output) {
  std::ifstream in(source_dir() + "/tests/cases/glass_smoke.toml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto edit = [&](const std::string& from, const std::string& to) {
    const auto at = text.find(from);
    if (at == std::string::npos) throw std::runtime_error("glass_smoke.toml has no '" + from + "'");
    text.replace(at, from.size(), to);
  };
  edit("count = 1781", "count = 300");
  edit("steps = 8000", "steps = 3000");
  edit("revolutions = 0.12", "revolutions = 0.02");
  edit("snapshot_every_s = 0.2", "snapshot_every_s = 0.05" + extra_output);
  edit("trace = true", "trace = false");
  return text;
}

std::set<std::string> names_in(const std::string& dir, const std::string& ext) {
  std::set<std::string> out;
  if (!fs::exists(dir)) return out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ext) out.insert(e.path().stem().string());
  return out;
}

}  // namespace

TEST(SpeedImages, OnePerSnapshotInDrumRunsShowingTheBedBelowTheAxis) {
  const std::string out = fresh_dir("speed_images_on");
  fs::create_directories(out);
  const std::string case_path = out + "_case.toml";
  std::ofstream(case_path) << small_drum("");
  const auto r = run_command(biodem_exe() + " run " + case_path + " --out " + out + " --threads 1");
  ASSERT_EQ(r.status, 0) << r.output;

  const auto vtu = names_in(out + "/snapshots", ".vtu"), png = names_in(out + "/speed_images", ".png");
  ASSERT_GE(vtu.size(), 3u);
  std::set<std::string> expected;
  for (const auto& v : vtu) expected.insert("speed_" + v.substr(v.find('_') + 1));  // spheres_NNNNNN -> speed_NNNNNN
  EXPECT_EQ(png, expected);

  const cv::Mat img = cv::imread(out + "/speed_images/" + *png.rbegin() + ".png", cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 512 + 130);  // frame_size_px (default 512) and the colour bar's band
  EXPECT_EQ(img.rows, 512 + 30);   // and the title's
  // Coloured pixels (neither grey nor white) of the drum's square: the beads; a settled bed lies
  // below the axis (row 30 + 255.5).
  int below = 0, above = 0;
  for (int row = 30; row < img.rows; ++row)
    for (int col = 0; col < 512; ++col) {
      const auto p = img.at<cv::Vec3b>(row, col);
      if (p[0] == p[1] && p[1] == p[2]) continue;
      (row > 30 + 255.5 ? below : above) += 1;
    }
  EXPECT_GT(below, 5000);  // 300 beads of 1 mm in a 30 mm drum drawn at 15.7 px/mm: each ~190 px
  EXPECT_LT(above, below / 10);
  const std::string log = slurp(out + "/run.log");
  EXPECT_NE(log.find("speed images at each snapshot (colour scale 0 to 0.06283 m/s)"), std::string::npos)
      << "twice the rim speed, 2 x 20 rpm x 2 pi / 60 x 15 mm";
}

TEST(SpeedImages, NoneWhenSwitchedOffAndTheScaleKeyThenWarned) {
  const std::string out = fresh_dir("speed_images_off");
  fs::create_directories(out);
  const std::string case_path = out + "_case.toml";
  std::ofstream(case_path) << small_drum("\nspeed_images = false\nspeed_image_max_m_s = 0.5");
  const auto r = run_command(biodem_exe() + " run " + case_path + " --out " + out + " --threads 1");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_FALSE(fs::exists(out + "/speed_images"));
  EXPECT_GE(names_in(out + "/snapshots", ".vtu").size(), 3u);
  EXPECT_NE(r.output.find("[output].speed_image_max_m_s is not used"), std::string::npos) << r.output;
}
