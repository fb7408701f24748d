// Case files (TOML) -> plain config structs. All validation of a case lives here (STYLE.md 6):
// every problem is reported as a biodem::Error whose one-line message names the key (with its
// table path, e.g. "[[pair]] #2 .restitution") or the file, and the reason.
#pragma once
#include <string>
#include <string_view>
#include <vector>

#include "config/case_config.hpp"

namespace biodem::case_file {

struct LoadedCase {
  config::CaseConfig config;
  std::vector<std::string> warnings;  // e.g. dt above 20 % of the Rayleigh time
};

/// Reads, parses and fully validates a case file. Throws biodem::Error.
LoadedCase load_case(const std::string& path);
/// Same for text already in memory (`source_name` is used in messages).
LoadedCase parse_case(std::string_view toml_text, const std::string& source_name);

}  // namespace biodem::case_file
