#pragma once
// A maps directory (docs/design.md "Maps directory") as the preview needs it:
// linear albedo, tangent-space normals, height, and the optional gloss and
// alpha maps a technician may add beside them (gloss.png, alpha.png: 8- or
// 16-bit grey, white = fully glossy / fully opaque).

#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"

namespace psrig::preview {

namespace swatch_files {
inline constexpr const char* kGloss = "gloss.png";
inline constexpr const char* kAlpha = "alpha.png";
}  // namespace swatch_files

// All images share one size, row 0 at the top of the swatch as scanned.
struct SwatchMaps {
  std::filesystem::path directory;
  cv::Mat albedo;  // CV_32FC3, linear R, G, B (RGB order, not OpenCV's BGR)
  cv::Mat normal;  // CV_32FC3, unit (x, y, z) in the scan's axes (docs/design.md "Axes and units")
  cv::Mat height;  // CV_32FC1 (height_units); empty when the directory has none
  cv::Mat gloss;   // CV_32FC1 in [0, 1]; empty: the renderer's uniform gloss
  cv::Mat alpha;   // CV_32FC1 in [0, 1]; empty: opaque
  double pixel_size_mm = 0;  // 0: not known (report.json says null or is absent)
  std::string height_units = "px";
  std::string sample_id;

  [[nodiscard]] cv::Size size() const { return albedo.size(); }
  // The swatch's extent in millimetres, or in pixels when the pixel size
  // is not known.
  [[nodiscard]] cv::Size2d extent() const;
};

// Albedo from albedo.exr (else albedo.png, sRGB decoded), normals from
// normal.png, height from height.exr, pixel size from report.json. Errors
// name the file that is missing, unreadable or of the wrong size.
[[nodiscard]] Result<SwatchMaps> load_swatch_maps(const std::filesystem::path& directory);

}  // namespace psrig::preview
