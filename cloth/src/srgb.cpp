#include "psrig/cloth/srgb.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>

namespace psrig::cloth {

float srgb_encode(float linear) {
  linear = std::clamp(linear, 0.0f, 1.0f);
  return linear <= 0.0031308f ? 12.92f * linear : 1.055f * std::pow(linear, 1.0f / 2.4f) - 0.055f;
}

float srgb_decode(float encoded) {
  encoded = std::clamp(encoded, 0.0f, 1.0f);
  return encoded <= 0.04045f ? encoded / 12.92f : std::pow((encoded + 0.055f) / 1.055f, 2.4f);
}

std::optional<Eigen::Vector3f> parse_srgb_hex(std::string_view text) {
  if (text.size() != 7 || text.front() != '#') return std::nullopt;
  for (const char c : text.substr(1))
    if (!std::isxdigit(static_cast<unsigned char>(c))) return std::nullopt;
  Eigen::Vector3f linear;
  for (int channel = 0; channel < 3; ++channel) {
    const char* first = text.data() + 1 + 2 * channel;
    unsigned value = 0;
    std::from_chars(first, first + 2, value, 16);
    linear[channel] = srgb_decode(static_cast<float>(value) / 255.0f);
  }
  return linear;
}

std::string format_srgb_hex(const Eigen::Vector3f& linear) {
  std::string text = "#";
  constexpr const char* kDigits = "0123456789ABCDEF";
  for (int channel = 0; channel < 3; ++channel) {
    const auto value = static_cast<int>(std::lround(srgb_encode(linear[channel]) * 255.0f));
    text += kDigits[value / 16];
    text += kDigits[value % 16];
  }
  return text;
}

}  // namespace psrig::cloth
