#pragma once
// Colours as people write them: "#RRGGBB", sRGB, hexadecimal (chart
// palettes, --yarn-color). The renderers want linear RGB.

#include <optional>
#include <string_view>

#include <Eigen/Core>

namespace psrig::preview {

// Linear RGB, or nothing when `text` is not exactly "#RRGGBB".
[[nodiscard]] std::optional<Eigen::Vector3f> parse_srgb_hex(std::string_view text);

}  // namespace psrig::preview
