#include "psrig/formats/scan_layout.h"

#include <algorithm>
#include <cctype>

#include <opencv2/core.hpp>

namespace psrig::formats {
namespace {

std::string frame(std::string_view stem, int depth) {
  return std::string(stem) + (depth == CV_32F ? ".exr" : ".png");
}

// "STEM" followed by a light number (without leading zeros) and a frame
// extension, as led_frame and flat_frame write them.
bool numbered_frame(std::string_view name, std::string_view stem) {
  if (!name.starts_with(stem)) return false;
  name.remove_prefix(stem.size());
  std::size_t digits = 0;
  while (digits < name.size() && std::isdigit(static_cast<unsigned char>(name[digits])))
    ++digits;
  if (digits == 0 || (digits > 1 && name[0] == '0')) return false;
  name.remove_prefix(digits);
  return std::ranges::find(scan_files::kFrameExtensions, name) !=
         std::end(scan_files::kFrameExtensions);
}

}  // namespace

namespace scan_files {

std::string led_frame(int k, int depth) {
  return frame("led" + std::to_string(k), depth);
}

std::string dark_frame(int depth) {
  return frame("dark", depth);
}

std::string flat_frame(int k, int depth) {
  return frame("flat" + std::to_string(k), depth);
}

std::string flat_frame(int k, std::string_view extension) {
  return "flat" + std::to_string(k) + std::string(extension);
}

bool is_scan_file(std::string_view name) {
  if (name == kDescription || name == kMask || name == kGroundTruthNormal ||
      name == kGroundTruthHeight)
    return true;
  for (const auto extension : kFrameExtensions)
    if (name.size() == 4 + extension.size() && name.starts_with("dark") &&
        name.ends_with(extension))
      return true;
  return numbered_frame(name, "led") || numbered_frame(name, "flat");
}

}  // namespace scan_files

namespace map_files {

bool is_map_file(std::string_view name) {
  return std::ranges::find(kAll, name) != std::end(kAll);
}

}  // namespace map_files

}  // namespace psrig::formats
