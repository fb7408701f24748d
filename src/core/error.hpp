// Error type for user-facing problems (bad input, impossible set-ups). The message is one line
// that names the key or file and the reason; the command line prints it and exits non-zero.
#pragma once
#include <stdexcept>
#include <string>

namespace biodem {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

/// An output that cannot be written: a folder or file of the output that cannot be created,
/// written, synced or renamed (a full disk, permissions, a file size limit), a name of the output
/// taken by something else, or an output folder another biodem process holds. Exit status 4
/// instead of 2, so that scripts (and a calibration campaign's scheduler) tell a failure of the
/// machine or the folder from a mistake in the input or what the parameters do.
class OutputError : public Error {
 public:
  explicit OutputError(const std::string& what) : Error(what) {}
};

/// A failure that is not the input's: an internal inconsistency, or a fault of the device (the
/// GPU engine's DeviceFault). Exit status 3, as an internal error, so that a calibration campaign
/// takes it for a crash (retried once by --resume) instead of what its parameters do.
class InternalError : public Error {
 public:
  explicit InternalError(const std::string& what) : Error(what) {}
};

}  // namespace biodem
