// libFuzzer harness for the case parser (issue 10, item 8): any bytes given to
// case_file::parse_case either parse, or are rejected with a biodem::Error whose message is one line.
// Anything else (another exception, a crash, a sanitizer report, a hang) is a finding.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string_view>

#include "core/error.hpp"
#include "case_file/case_parser.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    (void)biodem::case_file::parse_case(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.toml");
  } catch (const biodem::Error& e) {
    const char* m = e.what();
    if (std::strchr(m, '\n') != nullptr || m[0] == '\0') {
      std::fprintf(stderr, "error message is not one line: [%s]\n", m);
      std::abort();
    }
  }
  return 0;
}
