#pragma once
// The check the pattern parsers' tests (knit charts, weave matrices) share:
// a mistake in a file's text is bad input at its line and column, saying
// what is wrong. Header-only: it needs GoogleTest, which psrig_test_support
// (also linked by the benchmarks) does not.

#include <string>

#include <gtest/gtest.h>

#include "psrig/base/error.h"

namespace psrig::test {

// A mistake in a pattern file's text and the error it must give: where, and
// what it says.
struct BadPattern {
  const char* text;
  int line;
  int column;
  const char* says;
};

// Expects `error`, from parsing `bad.text` as `file`, to be bad input at
// `file`:line:column whose description contains `bad.says`.
inline void expect_bad_pattern_error(const Error& error, const std::string& file,
                                     const BadPattern& bad) {
  EXPECT_EQ(error.kind, ErrorKind::bad_input) << bad.text;
  EXPECT_EQ(error.line, bad.line) << bad.text;
  EXPECT_EQ(error.column, bad.column) << bad.text;
  const std::string where = file + ":" + std::to_string(bad.line) + ":";
  EXPECT_TRUE(error.describe().starts_with(where)) << error.describe();
  EXPECT_NE(error.describe().find(bad.says), std::string::npos) << error.describe();
}

}  // namespace psrig::test
