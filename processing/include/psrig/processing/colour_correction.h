#pragma once
// A rig's colour calibration applied to the albedo: the 3x3 matrix from
// the camera's linear RGB to linear sRGB (D65) that `psrig calibrate
// colour` fits to a ColorChecker, carried in scan.json's
// `colour_correction`.

#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "psrig/base/error.h"

namespace psrig::processing {

inline constexpr const char* kAlbedoColourSpace = "sRGB D65";

struct ColourCorrection {
  cv::Matx33d rgb_matrix;   // camera RGB (index 0 red) to linear sRGB D65
  std::string calibration;  // the calibration version it came from, when known
};

// scan.json's `colour_correction`: {"matrix": [[3x3]], "space": "sRGB D65",
// "calibration": "0003"}; absent or null: none. bad_input naming the key.
[[nodiscard]] Result<std::optional<ColourCorrection>> read_colour_correction(
    const nlohmann::json& scan_document, const std::filesystem::path& file);

// The matrix applied in linear light to a BGR image (CV_32FC3), in place.
// A one-channel image is left as it is.
void apply_colour_matrix(const cv::Matx33d& rgb_matrix, cv::Mat& linear_bgr);

}  // namespace psrig::processing
