#include "output/output_dir.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "core/error.hpp"

namespace biodem::output {
namespace fs = std::filesystem;

void prepare_output_dir(const std::string& dir, const std::string& label) {
  const std::string who = label.empty() ? dir : label + " " + dir;
  if (dir.empty()) throw Error(label + ": the output directory name is empty");
  std::error_code ec;
  const fs::file_status st = fs::status(dir, ec);
  if (fs::exists(st)) {
    if (!fs::is_directory(st)) throw OutputError(who + ": exists and is not a directory");
  } else {
    fs::create_directories(dir, ec);
    if (ec) throw OutputError(who + ": cannot create directory: " + ec.message());
  }
  const std::string probe = (fs::path(dir) / (".biodem-write-probe-" + std::to_string(::getpid()))).string();
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw OutputError(who + ": directory is not writable: " + std::strerror(errno));
  ::close(fd);
  if (::unlink(probe.c_str()) != 0) throw OutputError(who + ": cannot remove probe file " + probe + ": " + std::strerror(errno));
}

void write_file_atomic(const std::string& path, const std::string& content) {
  const std::string tmp = path + ".tmp";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw OutputError(tmp + ": cannot create file: " + std::strerror(errno));
  const char* p = content.data();
  std::size_t left = content.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      ::unlink(tmp.c_str());
      throw OutputError(tmp + ": cannot write: " + std::strerror(err));
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0 && errno != EINVAL && errno != EROFS) {  // EINVAL: file system without fsync
    const int err = errno;
    ::close(fd);
    ::unlink(tmp.c_str());
    throw OutputError(tmp + ": cannot sync to disk: " + std::strerror(err));
  }
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw OutputError(tmp + ": cannot close: " + std::strerror(err));
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw OutputError(path + ": cannot rename " + tmp + " over it: " + std::strerror(err));
  }
}

DirLock& DirLock::operator=(DirLock&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = o.fd_;
    o.fd_ = -1;
  }
  return *this;
}

DirLock::~DirLock() {
  if (fd_ >= 0) ::close(fd_);  // (closing releases the flock)
}

DirLock lock_output_dir(const std::string& dir, bool inherited_by_children) {
  const std::string path = (fs::path(dir) / ".biodem.lock").string();
  const int fd = ::open(path.c_str(), O_RDONLY | O_CREAT | (inherited_by_children ? 0 : O_CLOEXEC), 0644);
  if (fd < 0) throw OutputError("--out " + dir + ": cannot open " + path + ": " + std::strerror(errno));
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    if (err == EWOULDBLOCK) {
      ::close(fd);
      throw OutputError("--out " + dir + ": another biodem run is writing to this folder (" + path +
                  " is locked, by a run, or a calibration campaign or one of its test runs); wait for it to "
                  "end, or choose another --out");
    }
    // A file system without locks (some network and cluster mounts): the run goes on unguarded,
    // as before there was a lock.
  }
  return DirLock(fd);
}

}  // namespace biodem::output
