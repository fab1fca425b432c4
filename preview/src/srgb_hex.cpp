#include "psrig/preview/srgb_hex.h"

#include <cctype>
#include <charconv>

#include "psrig/preview/shading.h"

namespace psrig::preview {

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

}  // namespace psrig::preview
