// `biodem video FRAMES --fps F --rpm W --out DIR`: the centroid-angle and free-surface series of
// a back-lit drum film given as a folder of frames or a video file (SPEC 6, 11), written as
// DIR/series.csv in the same format as a simulation's, ready for `biodem analyze`. Also
// DIR/video_check.png: the first frame with the disc found, the powder mask and the surface
// profile, to check the set-up. Frames are read and measured in batches, so memory does not grow
// with the length of the film but for the rows of series.csv (some 50 bytes a frame), which are
// written whole, with video_check.png, only when the command succeeds (a temporary file renamed
// over the old one): a run that fails leaves the folder's earlier files as they were.
#include <omp.h>

#include <algorithm>
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
#include "analysis/video_frames.hpp"
#include "commands.hpp"
#include "core/error.hpp"
#include "output/analysis_files.hpp"
#include "output/output_dir.hpp"
#include "output/png_mat.hpp"
#include "output/progress.hpp"
#include "output/series_csv.hpp"

namespace biodem::cli {

namespace {

// Beds that look brighter than this part of the lit drum (FrameMeasure::bed_light, median over the
// frames), measured with a back-light fitted to each frame, are warned about (docs/analysis.md,
// video limits).
constexpr double kGreyBed = 0.5;

// The disc search reads up to this many readable frames (unreadable files do not count), trying
// the disc on up to kDiscTries of them.
constexpr std::size_t kDiscSearchFrames = 64;
constexpr std::size_t kDiscTries = 50;

namespace fs = std::filesystem;

struct VideoOptions {
  std::string frames;
  double fps = 0.0;
  double rpm = 0.0;
  std::string out;
  std::string rotation = "ccw";
  std::string background;
  std::vector<double> center_px;
  double radius_px = 0.0;
  int threshold = -1;
  double wall_zone_px = -1.0;
  int bin_px = 1;
  bool quiet = false;
  CLI::Option* radius_opt = nullptr;
  CLI::Option* threshold_opt = nullptr;
  CLI::Option* wall_zone_opt = nullptr;
};

std::string fmt(double v, const char* f = "%.4g") {
  char buf[48];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// True if a and b name the same existing folder (through links, "..", a trailing "/").
bool same_folder(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  if (fs::equivalent(a, b, ec)) return true;
  const fs::path ca = fs::weakly_canonical(a, ec);
  if (ec) return false;
  const fs::path cb = fs::weakly_canonical(b, ec);
  if (ec) return false;
  return ca.lexically_normal() == cb.lexically_normal();
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
  output::write_png(path.string(), rgb);
}

// First 10 names of a list, then the count of the others.
class NameList {
 public:
  void add(const std::string& name) {
    if (names_.size() < 10) names_.push_back(name);
    ++count_;
  }
  std::size_t size() const { return count_; }
  bool empty() const { return count_ == 0; }
  std::string str() const {
    std::ostringstream s;
    for (std::size_t i = 0; i < names_.size(); ++i) s << (i ? ", " : "") << names_[i];
    if (count_ > names_.size()) s << ", ... (" << count_ - names_.size() << " more)";
    return s.str();
  }

 private:
  std::vector<std::string> names_;
  std::size_t count_ = 0;
};

int run_video(const VideoOptions& o) {
  if (!(o.fps > 0.0) || !std::isfinite(o.fps)) throw Error("--fps must be > 0");
  if (!(o.rpm > 0.0) || !std::isfinite(o.rpm)) throw Error("--rpm must be > 0");
  if (o.bin_px < 1) throw Error("--bin-px must be >= 1");
  if (o.wall_zone_opt->count() && !(o.wall_zone_px >= 0.0 && std::isfinite(o.wall_zone_px)))
    throw Error("--wall-zone-px must be >= 0 (pixels; leave it out for 5 % of the disc radius)");
  const bool given_centre = !o.center_px.empty();
  const bool given_radius = o.radius_opt->count() > 0;
  if (given_centre != given_radius) throw Error("give --center-px and --radius-px together");
  if (given_radius && !(o.radius_px > 0.0)) throw Error("--radius-px must be > 0");

  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  cv::Mat background;
  if (!o.background.empty()) {
    std::error_code bec;
    if (!fs::is_regular_file(o.background, bec))
      throw Error("--background '" + o.background + "' does not exist or is not a file");
    try {
      background = analysis::to_grey8(cv::imread(o.background, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR));
    } catch (const cv::Exception&) {
      background.release();
    }
    if (background.empty()) throw Error("--background '" + o.background + "' cannot be read as an image");
  }
  const auto source = analysis::FrameSource::open(o.frames);
  if (source->is_video() && source->container_fps() > 0.0 &&
      std::abs(source->container_fps() - o.fps) > 0.01 * o.fps)
    std::cerr << "warning: --fps " << fmt(o.fps, "%g") << " differs from the video's own frame rate "
              << fmt(source->container_fps(), "%g") << " fps; times use --fps\n";

  // The output folder: not the frames' own (the next run would read video_check.png as a
  // frame), not a simulation run's (its series.csv would be replaced), locked for the command
  // (a run or another video writing there at the same time).
  const fs::path out_dir = o.out;
  if (!source->is_video() && same_folder(out_dir, o.frames))
    throw Error("--out '" + o.out + "' is the frames folder; choose another folder for series.csv and video_check.png");
  std::error_code ec;
  for (const char* run_file : {"run.log", "checkpoint.bin"})
    if (fs::exists(out_dir / run_file, ec))
      throw Error("--out '" + o.out + "' holds a simulation run's outputs (" + run_file +
                  "); biodem video would replace its series.csv: choose another --out");
  fs::create_directories(out_dir, ec);
  if (!fs::is_directory(out_dir, ec)) throw OutputError("cannot create output folder '" + o.out + "'");
  const output::DirLock lock = output::lock_output_dir(o.out);

  analysis::FrameParams params;
  params.rotation = o.rotation == "cw" ? analysis::Rotation::cw : analysis::Rotation::ccw;
  if (o.threshold_opt->count()) params.threshold = o.threshold;
  params.surface.bin_px = o.bin_px;
  params.surface.wall_zone_px = o.wall_zone_px;

  // The camera is fixed: the disc is found once, on the empty-drum background when given, else
  // on the first readable frame where its rim shows (frames taken while a drum is being filled
  // can hide most of the rim; up to kDiscTries are tried among the first kDiscSearchFrames
  // readable ones; unreadable files do not count). Frames read meanwhile are kept and measured
  // first.
  std::vector<analysis::VideoFrame> pending;
  analysis::DrumDisc disc{};
  std::string disc_from = "given";
  std::optional<cv::Size> size;
  std::string first_error;
  bool found = given_centre;
  if (given_centre) disc = {o.center_px[0], o.center_px[1], o.radius_px};
  if (!found && !background.empty()) {
    try {
      disc = analysis::find_drum_disc(background);
    } catch (const Error& e) {
      throw Error("--background '" + o.background + "': " + e.what());
    }
    found = true;
    disc_from = "found on the background";
  }
  for (std::size_t tried = 0, readable = 0; readable < kDiscSearchFrames;) {
    analysis::VideoFrame f;
    if (!source->next(f)) break;
    source->load(f);
    pending.push_back(std::move(f));
    const cv::Mat& img = pending.back().grey;
    if (img.empty()) continue;
    ++readable;
    if (!size) size = img.size();
    if (found) break;
    if (img.size() != *size || tried++ >= kDiscTries) continue;
    try {
      disc = analysis::find_drum_disc(img);
      found = true;
      disc_from = "found on " + pending.back().name;
      break;
    } catch (const Error& e) {
      if (first_error.empty()) first_error = pending.back().name + ": " + e.what();
    }
  }
  if (!size) {
    if (!source->is_video()) throw Error("none of the frames in '" + o.frames + "' can be read as an image");
    throw Error("no frame of the video '" + o.frames + "' can be decoded" +
                (source->container_frames() > 0
                     ? " (its container declares " + std::to_string(source->container_frames()) + " frames)"
                     : std::string()));
  }
  if (!found) throw Error(first_error.empty() ? "could not find the drum disc in '" + o.frames + "'" : first_error);
  if (!background.empty()) {
    if (background.size() != *size)
      throw Error("--background '" + o.background + "' is " + std::to_string(background.cols) + "x" +
                  std::to_string(background.rows) + " px, the frames " + std::to_string(size->width) + "x" +
                  std::to_string(size->height) + " px");
    params.illumination = analysis::background_illumination(background, disc);
  }
  if (!o.quiet)
    std::cerr << "drum disc: centre (" << fmt(disc.cx_px, "%.1f") << ", " << fmt(disc.cy_px, "%.1f")
              << ") px, radius " << fmt(disc.radius_px, "%.1f") << " px (" << disc_from << ")\n";
  cv::Mat check_frame;  // drawn into video_check.png when the command succeeds
  for (const auto& f : pending)
    if (!f.grey.empty() && f.grey.size() == *size) {
      check_frame = f.grey;
      break;
    }

  std::string rows = std::string(output::kSeriesHeader) + "\n";
  NameList unreadable, wrong_size, empty;
  std::size_t total = 0, measured = 0;
  std::size_t most_bins = 0;  // the most surface-profile bins of a frame with powder
  std::vector<double> bed_light;  // FrameMeasure::bed_light of the frames with powder
  output::Progress progress(std::cerr, output::Progress::stderr_is_terminal(), 5.0);
  const std::size_t batch = 16 * static_cast<std::size_t>(std::max(1, omp_get_max_threads()));
  std::vector<analysis::VideoFrame> frames;
  std::vector<analysis::FrameMeasure> results;
  enum class Status { unreadable, wrong_size, measured };
  std::vector<Status> status;
  std::size_t next_pending = 0;
  for (bool more = true; more;) {
    frames.clear();
    while (frames.size() < batch) {
      if (next_pending < pending.size()) {
        frames.push_back(std::move(pending[next_pending++]));
        continue;
      }
      analysis::VideoFrame f;
      if (!source->next(f)) {
        more = false;
        break;
      }
      frames.push_back(std::move(f));
    }
    if (next_pending == pending.size()) pending.clear();
    results.assign(frames.size(), analysis::FrameMeasure{});
    status.assign(frames.size(), Status::unreadable);
    const auto nb = static_cast<long>(frames.size());
#pragma omp parallel for schedule(dynamic, 1)
    for (long k = 0; k < nb; ++k) {
      auto& f = frames[static_cast<std::size_t>(k)];
      source->load(f);
      auto& st = status[static_cast<std::size_t>(k)];
      if (f.grey.empty()) continue;
      if (f.grey.size() != *size) {
        st = Status::wrong_size;
      } else {
        st = Status::measured;
        results[static_cast<std::size_t>(k)] = analysis::measure_backlit_frame(f.grey, disc, params);
      }
      f.grey.release();
    }
    for (std::size_t k = 0; k < frames.size(); ++k) {
      const auto& f = frames[k];
      const auto& m = results[k];
      ++total;
      if (status[k] == Status::unreadable) {
        unreadable.add(f.name);
        continue;
      }
      if (status[k] == Status::wrong_size) {
        wrong_size.add(f.name);
        continue;
      }
      if (!m.has_powder) empty.add(f.name);
      else ++measured;
      if (m.has_powder && std::isfinite(m.bed_light)) bed_light.push_back(m.bed_light);
      if (m.has_powder) most_bins = std::max(most_bins, m.surface.bins_used);
      output::SeriesRow row;
      row.time_s = static_cast<double>(f.index) / o.fps;
      row.revolution = o.rpm * row.time_s / 60.0;
      row.alpha_deg = m.alpha_deg;
      if (std::isfinite(m.surface.r2)) {
        row.surface_r2 = m.surface.r2;
        row.surface_angle_deg = m.surface.angle_deg;
      }
      output::append_series_row(rows, row);
    }
    if (!o.quiet && !frames.empty()) {
      const std::size_t n = std::max(source->size_hint(), total);
      progress.update(static_cast<double>(total) / static_cast<double>(n),
                      "frame " + std::to_string(total) + "/" + std::to_string(n),
                      static_cast<double>(frames.back().index) / o.fps);
    }
  }

  if (!o.quiet) progress.finish("measured " + std::to_string(measured) + " of " + std::to_string(total) + " frames");
  if (!unreadable.empty())
    std::cerr << "warning: skipped " << unreadable.size() << " unreadable frame(s): " << unreadable.str() << "\n";
  if (!wrong_size.empty())
    std::cerr << "warning: skipped " << wrong_size.size() << " frame(s) whose size differs from "
              << size->width << "x" << size->height << " px: " << wrong_size.str() << "\n";
  if (!empty.empty())
    std::cerr << "warning: no powder found in " << empty.size() << " frame(s) (alpha left empty): "
              << empty.str() << "\n";
  // A damaged or cut-short video: decoding stops at the first frame that cannot be decoded. The
  // container's count is an estimate for some formats (duration x frame rate): a warning, and
  // only when more than 2 frames and 1 % of the declared ones are missing.
  if (source->is_video() && source->container_frames() > total + std::max<std::size_t>(2, source->container_frames() / 100))
    std::cerr << "warning: the video '" << o.frames << "' declares " << source->container_frames()
              << " frames but only " << total << " could be decoded (a damaged or cut-short file?): series.csv ends at t = "
              << fmt(static_cast<double>(total - 1) / o.fps, "%.4g") << " s\n";
  if (measured > 0 && most_bins < 3)
    std::cerr << "warning: the surface profile has at most " << most_bins << " bin(s) in any frame, r^2 needs 3: "
              << "surface_r2 is empty for every frame (--bin-px " << o.bin_px << ", --wall-zone-px "
              << (o.wall_zone_opt->count() ? fmt(o.wall_zone_px, "%g") : "default " + fmt(0.05 * disc.radius_px, "%.3g"))
              << ", disc radius " << fmt(disc.radius_px, "%.1f") << " px)\n";
  // A bed passing over half the light cannot be told from the vignetting by a back-light fitted to
  // each frame (docs/analysis.md): the bed may then be found only in part.
  if (params.illumination.empty() && !bed_light.empty()) {
    std::sort(bed_light.begin(), bed_light.end());
    const std::size_t h = bed_light.size() / 2;
    const double level = bed_light.size() % 2 ? bed_light[h] : 0.5 * (bed_light[h - 1] + bed_light[h]);
    if (level > kGreyBed)
      std::cerr << "warning: the bed looks " << fmt(100.0 * level, "%.0f")
                << " % as bright as the lit drum (median over the frames); a back-light fitted to each frame cannot "
                   "tell a bed passing over half the light from the vignetting, so alpha and the surface may come "
                   "from part of the bed: give --background (a frame of the empty, lit drum)\n";
  }
  if (measured == 0) throw Error("no frame in '" + o.frames + "' showed powder in the drum disc");

  // Success: an earlier `biodem analyze` of the folder described the series replaced now, so its
  // tables and plots go first; then the new files, each whole (temporary file and rename).
  // (series.csv first: if it cannot be written, the folder keeps its earlier files)
  const fs::path series_path = out_dir / "series.csv";
  output::write_file_atomic(series_path.string(), rows);
  output::remove_analysis_outputs(o.out);
  if (!check_frame.empty()) write_check_image(out_dir / "video_check.png", check_frame, disc, params);
  std::cout << "wrote " << series_path.string() << " (" << measured << " frames, "
            << fmt(static_cast<double>(total) / o.fps, "%.3g") << " s at " << fmt(o.fps, "%g")
            << " fps)\n";
  return 0;
}

}  // namespace

Action register_video(CLI::App& app) {
  auto* sub = app.add_subcommand("video", kVideoSummary);
  auto o = std::make_shared<VideoOptions>();
  sub->add_option("FRAMES", o->frames,
                  "folder of frames (.png .jpg .jpeg .tif .tiff) or a video file OpenCV can decode")
      ->required();
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
                                     "raw grey level 0-255, darker or equal is powder, no flat field (default: Otsu "
                                     "of the flat-field corrected disc, per frame)")
                         ->check(CLI::Range(0, 255));
  sub->add_option("--background", o->background,
                  "image of the empty, lit drum from the same camera: flat-field reference for "
                  "uneven back-light and vignetting (default: the back-light is fitted per frame)");
  o->wall_zone_opt = sub->add_option("--wall-zone-px", o->wall_zone_px,
                                     "surface points closer than this (>= 0 px) to the rim are excluded from r^2 "
                                     "(default: 5 % of the radius)");
  sub->add_option("--bin-px", o->bin_px, "image columns per surface-profile bin, >= 1 (default 1)");
  sub->add_flag("--quiet", o->quiet, "no progress output");
  return [o] { return run_video(*o); };
}

}  // namespace biodem::cli
