#pragma once
// What the stitch-chart and weave-matrix formats share (config/patterns/
// README.md): files read whole, lines numbered from 1, `#` comments, an
// optional `name:` line, and errors that point at a line and column.

#include <filesystem>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "psrig/base/error.h"

namespace psrig::cloth::pattern_text {

// One line of the file, without its line break. Views into the text.
struct Line {
  int number = 0;         // 1-based
  std::string_view text;  // the whole line, comments included

  // The 1-based column of a character that `part` (a view into `text`)
  // starts at.
  [[nodiscard]] int column_of(std::string_view part) const {
    return static_cast<int>(part.data() - text.data()) + 1;
  }
};

[[nodiscard]] std::vector<Line> split_lines(std::string_view text);

// Everything before the first `#`.
[[nodiscard]] std::string_view strip_comment(std::string_view text);

[[nodiscard]] std::string_view trim(std::string_view text);

[[nodiscard]] bool is_space(char c);

// The value of a `name: ...` line (trimmed, comment already stripped), or
// nothing when the line is not one.
[[nodiscard]] std::optional<std::string_view> name_value(std::string_view code);

// `index` wrapped into [0, count): patterns tile, in both directions.
[[nodiscard]] inline int wrap(int index, int count) {
  const int r = index % count;
  return r < 0 ? r + count : r;
}

// A `key: value` line whose key is lower-case letters and underscores
// (not `name`): the key and the value (trimmed), else nothing.
struct KeyValue {
  std::string_view key, value;
};
[[nodiscard]] std::optional<KeyValue> key_value(std::string_view code);

// One of a pattern's physical sizes (`wales_per_cm: 7`, `yarn_mm: 0.42`): the
// keys it may have and where each goes. Errors name the line and column.
struct Measure {
  std::string_view key;
  float* value;
};
[[nodiscard]] Status read_measure(const std::filesystem::path& source, const Line& line,
                                  const KeyValue& entry, std::initializer_list<Measure> measures);

// A bad-input error at a place in `source` (column 0: the whole line).
[[nodiscard]] Error error_at(const std::filesystem::path& source, int line, int column,
                             std::string message);

// The whole file; else a bad_input error naming it when it is not there
// (or a directory), an io error when it cannot be read.
[[nodiscard]] Result<std::string> read_text_file(const std::filesystem::path& file);

}  // namespace psrig::cloth::pattern_text
