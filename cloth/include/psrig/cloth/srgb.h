#pragma once
// Colours as people write them: "#RRGGBB", sRGB, hexadecimal (chart
// palettes, --yarn-color), and the exact sRGB transfer functions
// (IEC 61966-2-1). The cloth and its renderers work in linear RGB.

#include <optional>
#include <string>
#include <string_view>

#include <Eigen/Core>

namespace psrig::cloth {

// For values in [0, 1] (clamped).
[[nodiscard]] float srgb_encode(float linear);
[[nodiscard]] float srgb_decode(float encoded);

// Linear RGB, or nothing when `text` is not exactly "#RRGGBB".
[[nodiscard]] std::optional<Eigen::Vector3f> parse_srgb_hex(std::string_view text);
// A linear RGB colour as "#RRGGBB" (sRGB, clamped to [0, 1], rounded).
[[nodiscard]] std::string format_srgb_hex(const Eigen::Vector3f& linear);

}  // namespace psrig::cloth
