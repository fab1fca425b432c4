#include "pattern_text.h"

#include <cerrno>
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
