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

}  // namespace biodem
