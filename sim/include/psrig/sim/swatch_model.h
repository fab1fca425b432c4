#pragma once
// The simulated world's textile: a knitted or woven swatch built by the
// cloth library (cloth/) from a stitch chart or weave matrix at its real
// gauge, laid flat under the camera and seen head-on. `psrig synth` renders
// it into a scan directory; the simulated rig (lights + camera) renders it
// under whichever LEDs are on.

#include <cstdint>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/sim/swatch_pattern.h"

namespace psrig::sim {

struct SwatchParams {
  SwatchPattern pattern;         // load_swatch_pattern()
  cv::Size size{640, 480};       // pixels
  double pixel_size_mm = 0.025;  // millimetres per pixel on the swatch
  std::uint64_t seed = 1;        // same seed, same swatch
  // The fabric turned counterclockwise (as seen) by this much on the rig.
  double rotation_deg = 0;
};

struct Swatch {
  cv::Mat height_mm;  // CV_32F, millimetres above the lowest point; row 0 is the image top
  cv::Mat normal;  // CV_32FC3 unit normals (nx, ny, nz) in camera axes: x right, y up, z to camera
  cv::Mat albedo;  // CV_32FC3 linear reflectance in OpenCV's BGR channel order, within [0, 1]
  double pixel_size_mm = 0.025;
  // Where the cloth lies: its plane (mm; courses along +x, wales along +y,
  // the origin at the lower left corner of the pattern's stitch or
  // crossing (0, 0)) to image pixels (column, row; 0 at the first pixel's
  // centre). Empty for targets that are not cloth.
  cv::Matx23d cloth_to_image = cv::Matx23d::zeros();
};

// Bad input when the pattern holds no cloth (a default SwatchParams).
[[nodiscard]] Result<Swatch> make_swatch(const SwatchParams& params);

}  // namespace psrig::sim
