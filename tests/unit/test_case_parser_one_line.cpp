// Findings of the case-parser fuzzer (issue 10, item 8; tests/fuzz/): error messages quote the
// case's own text, and a TOML error that echoed a newline, or a key or name holding an escaped
// newline, gave a message of several lines. Every rejected case must be one line.
#include <gtest/gtest.h>

#include <string>

#include "core/error.hpp"
#include "case_file/case_parser.hpp"

using namespace biodem;

namespace {
std::string error_of(const std::string& text) {
  try {
    case_file::parse_case(text, "case.toml");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(CaseParserOneLine, TomlSyntaxErrorEchoingANewlineIsOneLine) {
  const std::string m = error_of("[run]\ndt_s = 1e-5\nallow_large_dt = t\n");
  ASSERT_NE(m, "");
  EXPECT_NE(m.find("case.toml:3:"), std::string::npos) << m;
  EXPECT_NE(m.find("\\n"), std::string::npos) << m;  // the echoed newline, now escaped
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
}

TEST(CaseParserOneLine, KeyWithAnEscapedNewlineIsOneLine) {
  const std::string m = error_of("\"bad\\nkey\" = 1\n");
  ASSERT_NE(m, "");
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  EXPECT_NE(m.find("bad\\nkey"), std::string::npos) << m;  // shown escaped
}
