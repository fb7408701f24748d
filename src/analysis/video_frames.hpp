// Frames of a back-lit drum film (SPEC 6 video path, SPEC 11 `biodem video`): a folder of images
// or a video file, read in order one at a time so that a film of any length is processed in
// constant memory. Every frame is converted to 8-bit grey by the same function, so a video and
// the folder of its decoded frames give the same pixels.
#pragma once
#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace biodem::analysis {

/// 8-bit grey copy of an image: 1, 3 (BGR) or 4 (BGRA) channels, 8 or 16 bits (16-bit values
/// are divided by 257). Empty if the image is empty or of another type.
cv::Mat to_grey8(const cv::Mat& image);

/// True if the name ends in .png, .jpg, .jpeg, .tif or .tiff (any case).
bool is_frame_file(const std::filesystem::path& p);

/// Natural order of names: digit runs compare as numbers (f2 before f10).
bool natural_less(const std::string& a, const std::string& b);

/// The frame files of a folder in natural order. Throws biodem::Error when the folder is missing,
/// not a folder, or holds no frame file.
std::vector<std::filesystem::path> list_frame_files(const std::string& folder);

struct VideoFrame {
  std::size_t index = 0;  // position in the film: time = index / fps
  std::string name;       // file name, or "frame N" for a video
  std::filesystem::path path;  // folder frames: the file, read by load()
  cv::Mat grey;           // after load(): empty if the frame could not be read
};

class FrameSource {
 public:
  /// A folder of frames, or any video file OpenCV's VideoCapture opens (.avi, .mp4, ...).
  /// Throws biodem::Error naming the path when it is missing or cannot be opened. For a video,
  /// what FFmpeg or GStreamer print on stderr while the file is opened and decoded is kept off
  /// the terminal (stderr is pointed at /dev/null around those calls, then restored): the first
  /// line printed while opening a file that cannot be opened ends the error message instead.
  static std::unique_ptr<FrameSource> open(const std::string& path);
  virtual ~FrameSource() = default;
  /// Next frame in order (a video decodes it here; a folder only names the file); false at the end.
  virtual bool next(VideoFrame& f) = 0;
  /// Reads a frame named by next() into f.grey (folder frames; may run in parallel).
  virtual void load(VideoFrame& f) const = 0;
  /// Number of frames if known (a video container's count may be approximate), 0 otherwise.
  virtual std::size_t size_hint() const = 0;
  virtual bool is_video() const = 0;
  /// Frame rate stored in a video container (0 if none or a folder).
  virtual double container_fps() const { return 0.0; }
  /// Number of frames a video container declares (0 if it declares none, or a folder). It may be
  /// approximate for some codecs; more frames decoded than declared is not an error, fewer is
  /// warned about by `biodem video` (a damaged or cut-short file: decoding stops at the first
  /// frame that cannot be decoded).
  virtual std::size_t container_frames() const { return 0; }
};

}  // namespace biodem::analysis
