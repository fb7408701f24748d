#include "analysis/video_frames.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <string_view>
#include <system_error>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "core/error.hpp"

namespace biodem::analysis {

namespace fs = std::filesystem;

cv::Mat to_grey8(const cv::Mat& image) {
  if (image.empty()) return {};
  cv::Mat img = image;
  if (img.depth() == CV_16U) {
    img.convertTo(img, CV_8U, 1.0 / 257.0);
  } else if (img.depth() != CV_8U) {
    return {};
  }
  cv::Mat grey;
  switch (img.channels()) {
    case 1: grey = img.clone(); break;
    case 3: cv::cvtColor(img, grey, cv::COLOR_BGR2GRAY); break;
    case 4: cv::cvtColor(img, grey, cv::COLOR_BGRA2GRAY); break;
    default: return {};
  }
  return grey;
}

bool is_frame_file(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tif" || ext == ".tiff";
}

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

std::vector<fs::path> list_frame_files(const std::string& folder) {
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

namespace {

// A PNG file ends with its IEND chunk (length 0, "IEND", CRC). One that does not was cut short
// (a copy or a recording interrupted): libpng would print its own "libpng error" line on
// stderr before the decoder gives up, so it is not handed to the decoder.
bool truncated_png(const fs::path& path) {
  std::string ext = path.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".png") return false;
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return true;
  const std::streamoff size = in.tellg();
  if (size < 20) return true;
  char tail[12];
  in.seekg(size - 12);
  in.read(tail, 12);
  return !in || std::string(tail + 4, 4) != "IEND";
}

class FolderSource final : public FrameSource {
 public:
  explicit FolderSource(const std::string& folder) : files_(list_frame_files(folder)) {}
  bool next(VideoFrame& f) override {
    if (pos_ >= files_.size()) return false;
    f = VideoFrame{};
    f.index = pos_;
    f.path = files_[pos_];
    f.name = files_[pos_].filename().string();
    ++pos_;
    return true;
  }
  void load(VideoFrame& f) const override {
    if (!f.grey.empty() || f.path.empty()) return;
    if (truncated_png(f.path)) return;  // unreadable: skipped with the one-line warning of video
    try {
      f.grey = to_grey8(cv::imread(f.path.string(), cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR));
    } catch (const cv::Exception&) {
      f.grey.release();
    }
  }
  std::size_t size_hint() const override { return files_.size(); }
  bool is_video() const override { return false; }

 private:
  std::vector<fs::path> files_;
  std::size_t pos_ = 0;
};

// Points stderr (file descriptor 2) at `fd` while it lives, then restores it. FFmpeg and
// GStreamer print their own lines on stderr ("moov atom not found", "Invalid data found when
// processing input", decoder complaints about a damaged frame) while a video is opened and
// decoded; they would make biodem's one-line error or warning several lines. Used only around
// those calls, on the one thread that reads the video (frames are measured between reads, not
// during them), so biodem's own messages are never lost. Does nothing if fd < 0 or stderr cannot
// be duplicated.
class StderrTo {
 public:
  explicit StderrTo(int fd) {
    if (fd < 0) return;
    std::cerr.flush();
    std::fflush(stderr);
    saved_ = ::fcntl(STDERR_FILENO, F_DUPFD_CLOEXEC, 0);
    if (saved_ >= 0 && ::dup2(fd, STDERR_FILENO) < 0) {
      ::close(saved_);
      saved_ = -1;
    }
  }
  ~StderrTo() {
    if (saved_ < 0) return;
    std::fflush(stderr);
    ::dup2(saved_, STDERR_FILENO);
    ::close(saved_);
  }
  StderrTo(const StderrTo&) = delete;
  StderrTo& operator=(const StderrTo&) = delete;

 private:
  int saved_ = -1;
};

// The first non-empty line of what was written to `f`, without FFmpeg's "[demuxer @ 0x...] "
// prefix, at most 200 characters; "" if none.
std::string first_message(std::FILE* f) {
  if (!f) return {};
  std::fflush(f);
  std::rewind(f);
  char buf[4096];
  const std::size_t n = std::fread(buf, 1, sizeof buf, f);
  std::string_view text(buf, n);
  while (!text.empty()) {
    const std::size_t eol = text.find_first_of("\r\n");
    std::string_view line = text.substr(0, eol);
    text = eol == std::string_view::npos ? std::string_view{} : text.substr(eol + 1);
    if (line.starts_with('[')) {
      const std::size_t close = line.find("] ");
      if (close != std::string_view::npos) line.remove_prefix(close + 2);
    }
    while (!line.empty() && std::isspace(static_cast<unsigned char>(line.front()))) line.remove_prefix(1);
    while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.remove_suffix(1);
    if (line.empty()) continue;
    std::string out;
    for (char c : line.substr(0, 200)) out += std::isprint(static_cast<unsigned char>(c)) ? c : ' ';
    return out;
  }
  return {};
}

class VideoSource final : public FrameSource {
 public:
  explicit VideoSource(const std::string& path) : quiet_fd_(::open("/dev/null", O_WRONLY | O_CLOEXEC)) {
    bool opened = false;
    std::string said;
    {
      // What the back-ends print while opening is kept, to name the reason in the error.
      std::FILE* log = std::tmpfile();
      {
        StderrTo redirect(log ? fileno(log) : quiet_fd_);
        try {
          opened = cap_.open(path, cv::CAP_ANY);
        } catch (const cv::Exception&) {
          opened = false;
        }
        opened = opened && cap_.isOpened();
        if (opened) {
          const double n = cap_.get(cv::CAP_PROP_FRAME_COUNT);
          count_ = n > 0.0 && n < 1e9 ? static_cast<std::size_t>(n) : 0;
          fps_ = cap_.get(cv::CAP_PROP_FPS);
          if (!(fps_ > 0.0) || fps_ > 1e6) fps_ = 0.0;
        }
      }
      if (!opened) said = first_message(log);
      if (log) std::fclose(log);
    }
    if (!opened) {
      close_quiet();
      throw Error("cannot open video '" + path + "' (not a video OpenCV can decode" +
                  (said.empty() ? std::string() : ": " + said) + ")");
    }
  }
  ~VideoSource() override {
    {
      StderrTo redirect(quiet_fd_);
      cap_.release();
    }
    close_quiet();
  }
  VideoSource(const VideoSource&) = delete;
  VideoSource& operator=(const VideoSource&) = delete;

  bool next(VideoFrame& f) override {
    cv::Mat img;
    bool ok = false;
    {
      StderrTo redirect(quiet_fd_);
      try {
        ok = cap_.read(img);
      } catch (const cv::Exception&) {
        ok = false;
      }
    }
    // The end of the film, or a frame that cannot be decoded (a damaged or cut-short file: the
    // caller compares the count with container_frames()).
    if (!ok || img.empty()) return false;
    f = VideoFrame{};
    f.index = pos_;
    f.name = "frame " + std::to_string(pos_);
    f.grey = to_grey8(img);
    ++pos_;
    return true;
  }
  void load(VideoFrame&) const override {}
  std::size_t size_hint() const override { return std::max(count_, pos_); }
  bool is_video() const override { return true; }
  double container_fps() const override { return fps_; }
  std::size_t container_frames() const override { return count_; }

 private:
  void close_quiet() {
    if (quiet_fd_ >= 0) ::close(quiet_fd_);
    quiet_fd_ = -1;
  }

  int quiet_fd_ = -1;  // /dev/null, for stderr while a frame is decoded
  cv::VideoCapture cap_;
  std::size_t count_ = 0, pos_ = 0;
  double fps_ = 0.0;
};

}  // namespace

std::unique_ptr<FrameSource> FrameSource::open(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error("frames folder or video '" + path + "' does not exist");
  if (fs::is_directory(path, ec)) return std::make_unique<FolderSource>(path);
  if (!fs::is_regular_file(path, ec)) throw Error("frames '" + path + "' is not a folder or a video file");
  return std::make_unique<VideoSource>(path);
}

}  // namespace biodem::analysis
