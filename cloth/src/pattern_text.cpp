#include "pattern_text.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

namespace psrig::cloth::pattern_text {

std::vector<Line> split_lines(std::string_view text) {
  std::vector<Line> lines;
  int number = 1;
  while (!text.empty()) {
    const std::size_t end = text.find('\n');
    std::string_view line = text.substr(0, end);
    if (line.ends_with('\r')) line.remove_suffix(1);  // files saved on Windows
    lines.push_back({number++, line});
    if (end == std::string_view::npos) break;
    text.remove_prefix(end + 1);
  }
  return lines;
}

std::string_view strip_comment(std::string_view text) {
  return text.substr(0, text.find('#'));
}

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\v' || c == '\f';
}

std::string_view trim(std::string_view text) {
  while (!text.empty() && is_space(text.front()))
    text.remove_prefix(1);
  while (!text.empty() && is_space(text.back()))
    text.remove_suffix(1);
  return text;
}

std::optional<std::string_view> name_value(std::string_view code) {
  constexpr std::string_view kKey = "name:";
  if (!code.starts_with(kKey)) return std::nullopt;
  return trim(code.substr(kKey.size()));
}

std::optional<KeyValue> key_value(std::string_view code) {
  std::size_t end = 0;
  while (end < code.size() && (std::islower(static_cast<unsigned char>(code[end])) || code[end] == '_'))
    ++end;
  if (end == 0 || end >= code.size() || code[end] != ':') return std::nullopt;
  const std::string_view key = code.substr(0, end);
  if (key == "name") return std::nullopt;
  return KeyValue{key, trim(code.substr(end + 1))};
}

Status read_measure(const std::filesystem::path& source, const Line& line, const KeyValue& entry,
                    std::initializer_list<Measure> measures) {
  std::string known;
  for (const Measure& measure : measures) {
    known += (known.empty() ? "" : ", ") + std::string(measure.key);
    if (measure.key != entry.key) continue;
    const std::string text(entry.value);
    char* end = nullptr;
    const float value = std::strtof(text.c_str(), &end);
    if (text.empty() || end != text.c_str() + text.size() || !(value > 0) || !std::isfinite(value))
      return std::unexpected(error_at(source, line.number, line.column_of(entry.value),
                                      std::string(entry.key) + " must be a positive number, not '" +
                                          text + "'"));
    if (*measure.value > 0)
      return std::unexpected(error_at(source, line.number, line.column_of(entry.key),
                                      "a second `" + std::string(entry.key) + ":` line"));
    *measure.value = value;
    return {};
  }
  return std::unexpected(error_at(source, line.number, line.column_of(entry.key),
                                  "unknown key '" + std::string(entry.key) + "': this file takes " +
                                      known + " and name"));
}

Error error_at(const std::filesystem::path& source, int line, int column, std::string message) {
  Error error = bad_input(source, {}, std::move(message));
  error.line = line;
  error.column = column;
  return error;
}

Result<std::string> read_text_file(const std::filesystem::path& file) {
  std::error_code ignored;
  if (std::filesystem::is_directory(file, ignored))
    return std::unexpected(bad_input(file, {}, "is a directory, not a pattern file"));
  // A pattern that is not there is the user's to fix (exit 2), like any
  // file named wrongly; one that cannot be read is the machine's.
  if (!std::filesystem::exists(file, ignored))
    return std::unexpected(bad_input(file, {}, "no such pattern file"));
  std::ifstream in(file, std::ios::binary);
  if (!in)
    return std::unexpected(io_error(file, std::string("cannot read: ") + std::strerror(errno)));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return std::unexpected(io_error(file, "read failed"));
  return std::move(text).str();
}

}  // namespace psrig::cloth::pattern_text
