#include "psrig/base/width_height.h"

#include <charconv>

namespace psrig {
namespace {

std::optional<int> parse_unsigned(std::string_view text) {
  if (text.empty() || text.front() < '0' || text.front() > '9') return std::nullopt;  // no sign
  int value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc{} || end != text.data() + text.size()) return std::nullopt;
  return value;
}

}  // namespace

std::optional<WidthHeight> parse_width_height(std::string_view text) {
  const auto x = text.find_first_of("xX");
  if (x == std::string_view::npos) return std::nullopt;
  const auto width = parse_unsigned(text.substr(0, x));
  const auto height = parse_unsigned(text.substr(x + 1));
  if (!width || !height) return std::nullopt;
  return WidthHeight{*width, *height};
}

}  // namespace psrig
