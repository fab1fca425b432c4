#pragma once
// A scan directory in the psrig-scan/1 layout (docs/design.md "Scan directory"):
// what scan.json says, and the frames it names.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace psrig::formats {

inline constexpr const char* kScanFormat = "psrig-scan/1";

// Full scale of a frame depth: 255, 65535, or 1.0 for float frames.
[[nodiscard]] inline double full_scale(int depth) {
  return depth == CV_8U ? 255.0 : depth == CV_16U ? 65535.0 : 1.0;
}
// "8-bit", "16-bit", "32-bit float".
[[nodiscard]] inline const char* depth_name(int depth) {
  return depth == CV_8U    ? "8-bit"
         : depth == CV_16U ? "16-bit"
         : depth == CV_32F ? "32-bit float"
                           : "unsupported";
}

enum class Encoding { linear, srgb };

struct ScanLight {
  std::string image;                 // file name inside the scan directory
  cv::Vec3d direction{0, 0, 1};      // unit vector from the swatch toward the light, camera axes
  cv::Vec3d intensity_bgr{1, 1, 1};  // relative irradiance per channel, OpenCV's BGR order
  bool intensity_is_rgb = false;     // scan.json gave [r, g, b] rather than one number
  // A near LED's position in mm, camera axes, origin where the camera axis
  // (principal_point_px) meets the swatch plane; `intensity` is then its
  // irradiance at normal incidence at that origin. Absent: a distant light.
  std::optional<cv::Vec3d> position_mm;
};

// scan.json, validated. Holds no pixels.
struct ScanDescription {
  std::filesystem::path directory;
  nlohmann::json document;  // the whole file, unknown keys included, for reports and rewriting
  std::string sample_id;
  std::string sample_description;
  Encoding encoding = Encoding::linear;
  double black_level = 0;
  std::optional<double> white_level;  // absent: the frames' full scale
  std::optional<std::string> dark;
  std::optional<std::string> mask;
  std::vector<std::string> flats;  // empty, or one white-target frame per light
  std::vector<ScanLight> lights;
  std::optional<double> pixel_size_mm;
  // Where the camera axis meets the image, in pixels (x = column, y = row,
  // 0 at the first pixel's centre). Absent: the image centre, ((w-1)/2, (h-1)/2).
  std::optional<cv::Point2d> principal_point_px;
  // Every light has a position (near-field LEDs); the reader allows all or none.
  [[nodiscard]] bool near_field() const {
    return !lights.empty() && lights.front().position_mm.has_value();
  }
  std::optional<std::string> ground_truth_normal;  // written by the simulator and `psrig synth`
  std::optional<std::string> ground_truth_height;
};

// A scan with its images loaded as stored: CV_8U, CV_16U or CV_32F, one
// channel (grey) or three (BGR), all the same size, channels and depth.
struct Scan {
  ScanDescription description;
  double white_level = 0;       // description.white_level or the frames' full scale
  std::vector<cv::Mat> frames;  // one per light, in the order of description.lights
  cv::Mat dark;                 // empty when the scan has none
  cv::Mat mask;                 // CV_8U, nonzero = pixel to solve; empty = all
  std::vector<cv::Mat> flats;   // empty, or one per light
  cv::Mat ground_truth_normal;  // CV_32FC3 (nx, ny, nz) in camera axes, or empty
  cv::Mat ground_truth_height;  // CV_32F, millimetres (or pixels without pixel_size_mm), or empty

  [[nodiscard]] cv::Size size() const {
    return frames.empty() ? cv::Size() : frames.front().size();
  }
  [[nodiscard]] int channels() const { return frames.empty() ? 0 : frames.front().channels(); }
  [[nodiscard]] int depth() const { return frames.empty() ? -1 : frames.front().depth(); }
};

}  // namespace psrig::formats
