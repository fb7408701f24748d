// `biodem video FRAMES --fps F --rpm W --out DIR`: the centroid-angle and free-surface series of
// a back-lit drum film given as a folder of frames (SPEC 6, 11), written as DIR/series.csv in
// the same format as a simulation's, ready for `biodem analyze`. Also DIR/video_check.png: the
// first frame with the disc found, the powder mask and the surface profile, to check the set-up.
#include <omp.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "analysis/backlit_image.hpp"
#include "commands.hpp"
#include "core/error.hpp"
#include "io/progress.hpp"
#include "io/series_csv.hpp"

namespace biodem::cli {

namespace {

namespace fs = std::filesystem;

struct VideoOptions {
  std::string frames;
  double fps = 0.0;
  double rpm = 0.0;
  std::string out;
  std::string rotation = "ccw";
  std::vector<double> center_px;
  double radius_px = 0.0;
  int threshold = -1;
  double wall_zone_px = -1.0;
  int bin_px = 1;
  bool quiet = false;
  CLI::Option* radius_opt = nullptr;
  CLI::Option* threshold_opt = nullptr;
};

bool is_frame_file(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tif" || ext == ".tiff";
}

// Natural order: digit runs compare as numbers, so frame2 < frame10 (zero-padded names sort the
// same as plain lexicographic order).
bool natural_less(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit(static_cast<unsigned char>(a[i])) && std::isdigit(static_cast<unsigned char>(b[j]))) {
      std::size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      std::string_view da(a.data() + i, ie - i), db(b.data() + j, je - j);
      while (da.size() > 1 && da.front() == '0') da.remove_prefix(1);
      while (db.size() > 1 && db.front() == '0') db.remove_prefix(1);
      if (da.size() != db.size()) return da.size() < db.size();
      if (da != db) return da < db;
      i = ie;
      j = je;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i;
      ++j;
    }
  }
  if ((a.size() - i) != (b.size() - j)) return (a.size() - i) < (b.size() - j);
  return a < b;
}

std::vector<fs::path> list_frames(const std::string& folder) {
  std::error_code ec;
  if (!fs::exists(folder, ec)) throw Error("frames folder '" + folder + "' does not exist");
  if (!fs::is_directory(folder, ec)) throw Error("frames '" + folder + "' is not a folder");
  std::vector<fs::path> frames;
  for (const auto& e : fs::directory_iterator(folder, ec))
    if (e.is_regular_file() && is_frame_file(e.path())) frames.push_back(e.path());
  if (ec) throw Error("cannot list frames folder '" + folder + "': " + ec.message());
  if (frames.empty())
    throw Error("no frames (.png, .jpg, .jpeg, .tif, .tiff) in folder '" + folder + "'");
  std::sort(frames.begin(), frames.end(), [](const fs::path& a, const fs::path& b) {
    return natural_less(a.filename().string(), b.filename().string());
  });
  return frames;
}

cv::Mat read_grey(const fs::path& p) {
  try {
    return cv::imread(p.string(), cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception&) {
    return {};
  }
}

std::string fmt(double v, const char* f = "%.4g") {
  char buf[48];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

void write_check_image(const fs::path& path, const cv::Mat& grey, const analysis::DrumDisc& disc,
                       const analysis::FrameParams& params) {
  cv::Mat rgb;
  cv::cvtColor(grey, rgb, cv::COLOR_GRAY2BGR);
  const cv::Mat mask = analysis::powder_mask(grey, disc, params);
  cv::Mat tint(rgb.size(), rgb.type(), cv::Scalar(40, 120, 255));
  cv::Mat blended;
  cv::addWeighted(rgb, 0.5, tint, 0.5, 0.0, blended);
  blended.copyTo(rgb, mask);
  constexpr int kShift = 3;
  auto P = [&](double x, double y) {
    return cv::Point(static_cast<int>(std::lround(x * (1 << kShift))),
                     static_cast<int>(std::lround(y * (1 << kShift))));
  };
  cv::circle(rgb, P(disc.cx_px, disc.cy_px), static_cast<int>(std::lround(disc.radius_px * (1 << kShift))),
             cv::Scalar(0, 200, 0), 2, cv::LINE_AA, kShift);
  cv::drawMarker(rgb, cv::Point(static_cast<int>(std::lround(disc.cx_px)), static_cast<int>(std::lround(disc.cy_px))),
                 cv::Scalar(0, 200, 0), cv::MARKER_CROSS, 15, 1);
  analysis::ImageSurfaceParams sp = params.surface;
  sp.mirror_x = params.rotation == analysis::Rotation::cw;
  const double sign = sp.mirror_x ? -1.0 : 1.0;
  for (const auto& q : analysis::free_surface_profile_mask(mask, disc.cx_px, disc.cy_px, disc.radius_px, sp))
    cv::circle(rgb, P(disc.cx_px + sign * q.x, disc.cy_px - q.y), 1 << kShift, cv::Scalar(255, 0, 0),
               cv::FILLED, cv::LINE_AA, kShift);
  if (!cv::imwrite(path.string(), rgb)) throw Error("cannot write '" + path.string() + "'");
}

int run_video(const VideoOptions& o) {
  if (!(o.fps > 0.0) || !std::isfinite(o.fps)) throw Error("--fps must be > 0");
  if (!(o.rpm > 0.0) || !std::isfinite(o.rpm)) throw Error("--rpm must be > 0");
  if (o.bin_px < 1) throw Error("--bin-px must be >= 1");
  const bool given_centre = !o.center_px.empty();
  const bool given_radius = o.radius_opt->count() > 0;
  if (given_centre != given_radius) throw Error("give --center-px and --radius-px together");
  if (given_radius && !(o.radius_px > 0.0)) throw Error("--radius-px must be > 0");

  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  const std::vector<fs::path> frames = list_frames(o.frames);

  const fs::path out_dir = o.out;
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (!fs::is_directory(out_dir)) throw Error("cannot create output folder '" + o.out + "'");

  analysis::FrameParams params;
  params.rotation = o.rotation == "cw" ? analysis::Rotation::cw : analysis::Rotation::ccw;
  if (o.threshold_opt->count()) params.threshold = o.threshold;
  params.surface.bin_px = o.bin_px;
  params.surface.wall_zone_px = o.wall_zone_px;

  // The camera is fixed: the disc is found once, on the first readable frame where its rim shows
  // (frames taken while a drum is being filled can hide most of the rim; up to 50 are tried).
  std::size_t first = 0;
  cv::Mat first_img;
  for (; first < frames.size(); ++first) {
    first_img = read_grey(frames[first]);
    if (!first_img.empty()) break;
  }
  if (first_img.empty())
    throw Error("none of the " + std::to_string(frames.size()) + " frames in '" + o.frames +
                "' can be read as an image");
  analysis::DrumDisc disc;
  if (given_centre) {
    disc = {o.center_px[0], o.center_px[1], o.radius_px};
  } else {
    std::string first_error;
    bool found = false;
    for (std::size_t k = first, tried = 0; k < frames.size() && tried < 50 && !found; ++k) {
      const cv::Mat img = k == first ? first_img : read_grey(frames[k]);
      if (img.empty()) continue;
      ++tried;
      try {
        disc = analysis::find_drum_disc(img);
        found = true;
        first = k;
        first_img = img;
      } catch (const Error& e) {
        if (first_error.empty()) first_error = frames[k].filename().string() + ": " + e.what();
      }
    }
    if (!found) throw Error(first_error);
  }
  if (!o.quiet)
    std::cerr << "drum disc: centre (" << fmt(disc.cx_px, "%.1f") << ", " << fmt(disc.cy_px, "%.1f")
              << ") px, radius " << fmt(disc.radius_px, "%.1f") << " px"
              << (given_centre ? " (given)" : " (found on " + frames[first].filename().string() + ")")
              << "\n";
  write_check_image(out_dir / "video_check.png", first_img, disc, params);

  struct Row {
    bool read = false;
    bool size_ok = true;
    analysis::FrameMeasure m;
  };
  const std::size_t n = frames.size();
  std::vector<Row> rows(n);
  io::Progress progress(std::cerr, io::Progress::stderr_is_terminal(), 5.0);
  const std::size_t batch = 32 * static_cast<std::size_t>(std::max(1, omp_get_max_threads()));
  for (std::size_t b0 = 0; b0 < n; b0 += batch) {
    const auto b1 = static_cast<long>(std::min(n, b0 + batch));
#pragma omp parallel for schedule(dynamic, 1)
    for (long i = static_cast<long>(b0); i < b1; ++i) {
      Row& r = rows[static_cast<std::size_t>(i)];
      const cv::Mat img = read_grey(frames[static_cast<std::size_t>(i)]);
      if (img.empty()) continue;
      r.read = true;
      if (img.size() != first_img.size()) {
        r.size_ok = false;
        continue;
      }
      r.m = analysis::measure_backlit_frame(img, disc, params);
    }
    if (!o.quiet)
      progress.update(static_cast<double>(b1) / static_cast<double>(n),
                      "frame " + std::to_string(b1) + "/" + std::to_string(n),
                      static_cast<double>(b1 - 1) / o.fps);
  }

  io::SeriesWriter writer(out_dir / "series.csv", false);
  std::vector<std::string> unreadable, wrong_size, empty;
  for (std::size_t i = 0; i < n; ++i) {
    const Row& r = rows[i];
    const std::string name = frames[i].filename().string();
    if (!r.read) {
      unreadable.push_back(name);
      continue;
    }
    if (!r.size_ok) {
      wrong_size.push_back(name);
      continue;
    }
    if (!r.m.has_powder) empty.push_back(name);
    io::SeriesRow row;
    row.time_s = static_cast<double>(i) / o.fps;
    row.revolution = o.rpm * row.time_s / 60.0;
    row.alpha_deg = r.m.alpha_deg;
    if (std::isfinite(r.m.surface.r2)) {
      row.surface_r2 = r.m.surface.r2;
      row.surface_angle_deg = r.m.surface.angle_deg;
    }
    writer.write(row);
  }
  writer.flush();

  auto list = [](const std::vector<std::string>& v) {
    std::ostringstream s;
    for (std::size_t i = 0; i < std::min<std::size_t>(v.size(), 10); ++i) s << (i ? ", " : "") << v[i];
    if (v.size() > 10) s << ", ... (" << v.size() - 10 << " more)";
    return s.str();
  };
  const std::size_t measured = n - unreadable.size() - wrong_size.size() - empty.size();
  if (!o.quiet)
    progress.finish("measured " + std::to_string(measured) + " of " + std::to_string(n) + " frames");
  if (!unreadable.empty())
    std::cerr << "warning: skipped " << unreadable.size() << " unreadable frame(s): " << list(unreadable) << "\n";
  if (!wrong_size.empty())
    std::cerr << "warning: skipped " << wrong_size.size() << " frame(s) whose size differs from "
              << frames[first].filename().string() << ": " << list(wrong_size) << "\n";
  if (!empty.empty())
    std::cerr << "warning: no powder found in " << empty.size() << " frame(s) (alpha left empty): "
              << list(empty) << "\n";
  if (measured == 0) throw Error("no frame in '" + o.frames + "' showed powder in the drum disc");
  std::cout << "wrote " << writer.path().string() << " (" << measured << " frames, "
            << fmt(static_cast<double>(n) / o.fps, "%.3g") << " s at " << fmt(o.fps, "%g")
            << " fps)\n";
  return 0;
}

}  // namespace

Action register_video(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "video",
      "Centroid angle alpha and surface r^2 series from a folder of back-lit drum frames "
      "(PNG/JPEG/TIFF, sorted by name) into DIR/series.csv, ready for analyze");
  auto o = std::make_shared<VideoOptions>();
  sub->add_option("FRAMES", o->frames, "folder of frames (.png .jpg .jpeg .tif .tiff)")->required();
  sub->add_option("--fps", o->fps, "frame rate (frames per second)")->required();
  sub->add_option("--rpm", o->rpm, "drum speed (rpm): revolution = rpm t / 60")->required();
  sub->add_option("--out", o->out, "output folder (series.csv, video_check.png)")->required();
  sub->add_option("--rotation", o->rotation,
                  "how the drum turns as seen in the images: ccw (bed rises on the right) or cw")
      ->check(CLI::IsMember({"ccw", "cw"}));
  sub->add_option("--center-px", o->center_px, "disc centre X Y in pixels (default: found)")
      ->expected(2);
  o->radius_opt = sub->add_option("--radius-px", o->radius_px, "disc radius in pixels (default: found)");
  o->threshold_opt = sub->add_option("--threshold", o->threshold,
                                     "grey level 0-255, darker or equal is powder (default: Otsu "
                                     "inside the disc, per frame)")
                         ->check(CLI::Range(0, 255));
  sub->add_option("--wall-zone-px", o->wall_zone_px,
                  "surface points closer than this to the rim are excluded from r^2 (default: 5 % "
                  "of the radius)");
  sub->add_option("--bin-px", o->bin_px, "image columns per surface-profile bin (default 1)");
  sub->add_flag("--quiet", o->quiet, "no progress output");
  return [o] { return run_video(*o); };
}

}  // namespace biodem::cli
