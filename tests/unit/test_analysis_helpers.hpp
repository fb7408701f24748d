// Shared helpers of the analysis tests: temporary folders, running the biodem binary, synthetic
// drum images and centroid-angle series.
#pragma once
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace biodem::test {

namespace fs = std::filesystem;

/// A fresh, empty folder under the system temp dir, removed at the end of the test.
class TempDir {
 public:
  explicit TempDir(const std::string& name) {
    path_ = fs::temp_directory_path() /
            ("biodem_" + name + "_" + std::to_string(static_cast<long>(::getpid())));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }
  fs::path operator/(const std::string& s) const { return path_ / s; }

 private:
  fs::path path_;
};

struct CommandResult {
  int status;          // exit status of biodem
  std::string output;  // stdout and stderr together
};

/// Runs the built biodem with the given arguments (already shell-quoted where needed).
inline CommandResult run_biodem(const std::string& args) {
  const std::string cmd = std::string("'") + BIODEM_BINARY + "' " + args + " 2>&1";
  CommandResult r{-1, {}};
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf{};
  std::size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), p)) > 0) r.output.append(buf.data(), n);
  const int st = ::pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

inline std::string quote(const fs::path& p) {
  std::string s(1, '\'');  // built in steps: GCC 12 warns (-Wrestrict) on "'" + s + "'" inlined
  s += p.string();
  s += '\'';
  return s;
}

inline std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

inline std::vector<std::string> read_lines(const fs::path& p) {
  std::ifstream in(p);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  return lines;
}

inline std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream s(line);
  for (std::string c; std::getline(s, c, ',');) cells.push_back(c);
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

/// Deterministic uniform noise in [-a, a].
class Noise {
 public:
  explicit Noise(std::uint64_t seed) : s_(seed) {}
  double uniform(double a) {
    s_ = s_ * 6364136223846793005ull + 1442695040888963407ull;
    const double u = static_cast<double>(s_ >> 11) / static_cast<double>(1ull << 53);
    return a * (2.0 * u - 1.0);
  }
  double gaussian(double sigma) {  // Box-Muller
    double u1 = 0.5 * (uniform(1.0) + 1.0), u2 = 0.5 * (uniform(1.0) + 1.0);
    if (u1 < 1e-300) u1 = 1e-300;
    return sigma * std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
  }

 private:
  std::uint64_t s_;
};

// ---------------------------------------------------------------- synthetic drum images
struct DrumImage {
  int size = 600;
  double cx = 300.0, cy = 300.0, radius = 250.0;
  int background = 40, disc = 230, powder = 20;
};

/// Disc mask (255 inside) drawn with the same rasteriser as the images.
inline cv::Mat drawn_disc(const DrumImage& d) {
  cv::Mat m(d.size, d.size, CV_8UC1, cv::Scalar(0));
  constexpr int kShift = 4;
  cv::circle(m, cv::Point(static_cast<int>(std::lround(d.cx * 16)), static_cast<int>(std::lround(d.cy * 16))),
             static_cast<int>(std::lround(d.radius * 16)), cv::Scalar(255), cv::FILLED, cv::LINE_8, kShift);
  return m;
}

/// Bed mask: pixels of the disc below the surface y_up(x) (drum-centred, y up, pixels), i.e.
/// image row > cy - surface(column - cx).
template <class Surface>
cv::Mat drawn_bed(const DrumImage& d, Surface surface) {
  cv::Mat m = drawn_disc(d);
  for (int i = 0; i < m.rows; ++i)
    for (int j = 0; j < m.cols; ++j) {
      const double x = j - d.cx, y_up = d.cy - i;
      if (y_up > surface(x)) m.at<std::uint8_t>(i, j) = 0;
    }
  return m;
}

/// Back-lit image: background, bright disc, dark bed.
inline cv::Mat backlit_image(const DrumImage& d, const cv::Mat& bed) {
  cv::Mat img(d.size, d.size, CV_8UC1, cv::Scalar(d.background));
  img.setTo(cv::Scalar(d.disc), drawn_disc(d));
  img.setTo(cv::Scalar(d.powder), bed);
  return img;
}

/// Centroid angle of a pixel mask (SPEC 6), y up.
inline double mask_alpha_deg(const cv::Mat& mask, double cx, double cy) {
  const cv::Moments mo = cv::moments(mask, true);
  const double xc = mo.m10 / mo.m00 - cx, yc = cy - mo.m01 / mo.m00;
  return 90.0 + std::atan2(xc, -yc) * 180.0 / std::numbers::pi;
}

/// A flat surface of slope angle theta through height c (pixels, y up).
inline auto flat_surface(double theta_deg, double c) {
  const double t = std::tan(theta_deg * std::numbers::pi / 180.0);
  return [t, c](double x) { return c + t * x; };
}

}  // namespace biodem::test
