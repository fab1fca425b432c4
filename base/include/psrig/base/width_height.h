#pragma once
// "WIDTHxHEIGHT" as people write a size (1920x1080, an x or X between two
// decimal numbers): the one parser behind `psrig synth --size`,
// psrig-preview's --size and the kiosk's display mode. Each caller checks
// the range it takes and words its own error.

#include <optional>
#include <string_view>

namespace psrig {

struct WidthHeight {
  int width = 0;
  int height = 0;
};

// Nothing unless the whole text is that: no sign, no spaces, each number
// within int.
[[nodiscard]] std::optional<WidthHeight> parse_width_height(std::string_view text);

}  // namespace psrig
