// Output directory and atomic file writes (SPEC 10: checkpoints are written atomically).
#pragma once
#include <string>

namespace biodem::output {

/// Creates `dir` (with parents) and proves it writable by creating and removing a probe file.
/// Throws biodem::Error "<label> <dir>: <what failed>: <reason>" (label defaults to "--out").
void prepare_output_dir(const std::string& dir, const std::string& label = "--out");

/// Writes `content` to `path + ".tmp"`, flushes and fsyncs it, then renames it over `path`, so
/// that a reader (or a run killed mid-write) sees either the old file or the complete new one.
/// Throws biodem::Error naming the path.
void write_file_atomic(const std::string& path, const std::string& content);

/// An exclusive lock on `dir` (flock on dir/.biodem.lock) held while the returned object lives:
/// two runs writing into one output folder would corrupt each other's files. Throws
/// biodem::Error naming the folder if another process holds it.
class DirLock {
 public:
  DirLock() = default;
  explicit DirLock(int fd) : fd_(fd) {}
  DirLock(const DirLock&) = delete;
  DirLock& operator=(const DirLock&) = delete;
  DirLock(DirLock&& o) noexcept : fd_(o.fd_) { o.fd_ = -1; }
  DirLock& operator=(DirLock&& o) noexcept;
  ~DirLock();

 private:
  int fd_ = -1;
};
/// `inherited_by_children`: the lock's descriptor is left open in the processes this one starts
/// (a calibration campaign's test runs), so that the folder stays locked while any of them lives,
/// also after the campaign itself was killed.
DirLock lock_output_dir(const std::string& dir, bool inherited_by_children = false);

}  // namespace biodem::output
