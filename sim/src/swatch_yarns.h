#pragma once
// The swatch's yarns as the camera sees them: the pattern's cloth
// (cloth::KnitFabric or cloth::WovenFabric) laid flat over the image at its
// gauge, with enough stitches to cover it turned, each loop or thread
// nudged a little about its place, turned by the swatch's rotation and
// handed over as the rasteriser's yarns, each with its look (colour along
// it, plies and twist).

#include <algorithm>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/cloth/yarn_raster.h"
#include "psrig/sim/swatch_pattern.h"

namespace psrig::sim::detail {

// How one yarn looks close up.
struct YarnLook {
  // Its colour (linear BGR, with the yarn's own dye-lot shade) in runs:
  // run k up to arc length run_end[k] (mm, as the rasteriser measures it).
  std::vector<float> run_end;
  std::vector<cv::Vec3f> run_bgr;
  float half_width_mm = 0;
  float twist_pitch_mm = 1;  // one full turn of the plies
  int plies = 2;
  float groove_mm = 0;  // depth of the groove between plies on top of the yarn
  std::uint64_t key = 0;

  [[nodiscard]] const cv::Vec3f& colour_at(float along_mm) const {
    const auto run = std::lower_bound(run_end.begin(), run_end.end() - 1, along_mm);
    return run_bgr[static_cast<std::size_t>(run - run_end.begin())];
  }
};

struct SwatchYarns {
  std::vector<cloth::RasterYarn> yarns;
  std::vector<YarnLook> looks;  // one per yarn
  float floor_mm = 0;           // the gaps: the deepest yarns' flanks
  cv::Vec3f gap_bgr;            // what shows through the gaps
  double smoothing_mm = 0;      // yarn surfaces are soft: a light blur
  double fibre_relief_mm = 0;   // fibre-scale roughness
  cv::Matx23d cloth_to_image;   // see Swatch::cloth_to_image
};

// `size` pixels of `px` mm; the fabric turned `rotation_deg` counterclockwise.
[[nodiscard]] Result<SwatchYarns> swatch_yarns(const SwatchPattern& pattern, cv::Size size,
                                               double px, double rotation_deg, std::uint64_t seed);

}  // namespace psrig::sim::detail
