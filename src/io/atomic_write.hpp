// Atomic file replacement: write to a temporary file in the same directory, flush, then rename
// over the target, so a reader (or a killed run) never sees a half-written file.
#pragma once
#include <string>

namespace biodem::io {

void replace_file_atomically(const std::string& path, const std::string& content);

}  // namespace biodem::io
