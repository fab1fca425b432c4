#pragma once
// What a map file says about itself beyond its pixels: its scale, its colour
// space and who it belongs to. PNGs carry it in pHYs, sRGB/gAMA/cHRM and
// text chunks; EXRs in header attributes (docs/design.md "Maps directory").

#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace psrig::formats {

struct ImageMetadata {
  // The pixel's edge on the swatch; PNG pHYs holds it as pixels per metre.
  std::optional<double> pixel_size_mm;
  // colour: sRGB-encoded colour (albedo), tagged sRGB with its gAMA and
  // cHRM; data: numbers (normals, heights, masks) tagged gamma 1.0 so no
  // viewer or DCC tool "corrects" them; unspecified: no colour chunk.
  enum class ColourSpace { unspecified, colour, data };
  ColourSpace colour_space = ColourSpace::unspecified;
  // Text entries, keyword then value (PNG tEXt, iTXt when not Latin-1
  // printable ASCII; EXR string attributes). Keywords: 1-79 ASCII printable.
  std::vector<std::pair<std::string, std::string>> text;

  [[nodiscard]] bool empty() const {
    return !pixel_size_mm && colour_space == ColourSpace::unspecified && text.empty();
  }
};

// The keywords psrig writes (PNG text chunks and EXR attributes alike).
namespace metadata_keys {
inline constexpr const char* kSample = "psrig:sample_id";
inline constexpr const char* kScanTime = "Creation Time";  // PNG's registered keyword
inline constexpr const char* kPixelSize = "psrig:pixel_size_mm";
inline constexpr const char* kUnits = "psrig:units";
inline constexpr const char* kHeightRange = "psrig:height_range";  // "LOW HIGH": 0 and 65535
inline constexpr const char* kNormalConvention = "psrig:normal_convention";
inline constexpr const char* kSoftware = "Software";
}  // namespace metadata_keys

}  // namespace psrig::formats
