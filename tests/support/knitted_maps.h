#pragma once
// A stitch chart knitted by the cloth model and seen head-on by an
// orthographic camera of known pixel size: the maps a perfect scan of it
// would give (height and albedo), and the truth to check chart inference
// against. Until the simulator renders charts (psrig synth --pattern), the
// chart-inference tests build their inputs with this.

#include <opencv2/core.hpp>

#include "psrig/cloth/stitch_chart.h"
#include "psrig/cloth/stitch_mesh.h"

namespace psrig::test {

struct KnittedMaps {
  cv::Mat height;  // CV_32F, mm, the topmost yarn (creases filled as the simulator fills them)
  cv::Mat albedo;  // CV_32FC3, linear BGR: each yarn's colour (the chart's palette)
  double pixel_size_mm = 0;
  // The fabric as knitted: stitches per cm across the wales and up the
  // course lines (the deformation included).
  double wales_per_cm = 0;
  double courses_per_cm = 0;
};

// `chart` knitted at its gauge (cloth::KnitFabric) over enough stitches to
// fill `size` pixels of `pixel_size_mm`, deformed in plane (stretch, shear),
// with Gaussian height noise of `noise_mm`.
[[nodiscard]] KnittedMaps knit_maps(const cloth::StitchChart& chart, cv::Size size,
                                    double pixel_size_mm, cloth::ClothDeformation deformation = {},
                                    double noise_mm = 0);

}  // namespace psrig::test
