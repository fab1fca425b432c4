#pragma once
// The simulated world's textile: a procedural knitted or woven swatch with
// the physical scale of real yarn. `psrig synth` renders it into a scan
// directory; the simulated rig (lights + camera) renders it under whichever
// LEDs are on.

#include <cstdint>
#include <optional>
#include <string_view>

#include <opencv2/core.hpp>

namespace psrig::sim {

enum class SwatchPattern { jersey, rib, garter, plain, twill };

// "jersey" | "rib" | "garter" | "plain" | "twill".
[[nodiscard]] std::optional<SwatchPattern> parse_swatch_pattern(std::string_view name);
[[nodiscard]] std::string_view to_string(SwatchPattern pattern);

struct SwatchParams {
  SwatchPattern pattern = SwatchPattern::jersey;
  cv::Size size{640, 480};       // pixels
  double pixel_size_mm = 0.025;  // millimetres per pixel on the swatch
  std::uint64_t seed = 1;        // same seed, same swatch
  // The fabric turned counterclockwise (as seen) by this much on the rig.
  double rotation_deg = 0;
};

// The swatch's gauge as made: a knit's wales and courses per cm (a 1x1
// rib's wales count knit and purl wales, garter's courses both ridges'
// courses), a woven's ends and picks per cm.
struct SwatchGauge {
  bool knitted = true;
  double across_per_cm = 0;  // wales or ends: threads met going across the image
  double along_per_cm = 0;   // courses or picks: going up it
};
[[nodiscard]] SwatchGauge swatch_gauge(SwatchPattern pattern);

struct Swatch {
  cv::Mat height_mm;  // CV_32F, millimetres above the lowest point; row 0 is the image top
  cv::Mat normal;  // CV_32FC3 unit normals (nx, ny, nz) in camera axes: x right, y up, z to camera
  cv::Mat albedo;  // CV_32FC3 linear reflectance in OpenCV's BGR channel order, within [0, 1]
  double pixel_size_mm = 0.025;
};

[[nodiscard]] Swatch make_swatch(const SwatchParams& params);

}  // namespace psrig::sim
