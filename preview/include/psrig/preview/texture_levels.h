#pragma once
// The swatch's textures exactly as uploaded to GL, mipmap levels included,
// built on the CPU so the CPU reference samples the very same texels:
// - albedo + alpha: 8-bit sRGB RGBA (GL_SRGB8_ALPHA8), levels averaged in
//   linear light before encoding;
// - normal + gloss: half-float RGBA (GL_RGBA16F), levels averaging the
//   unit normals without renormalising, so a level's normal is shorter
//   where the texels it covers disagree (the Toksvig term reads that).
// Rows are stored bottom row first, as GL's texture t axis runs up the
// swatch (docs/design.md "Normal-map convention": y up).

#include <vector>

#include <opencv2/core.hpp>

#include "psrig/preview/swatch_maps.h"

namespace psrig::preview {

struct TextureLevels {
  std::vector<cv::Mat> albedo_alpha;  // CV_8UC4 sRGB R, G, B, linear alpha
  std::vector<cv::Mat> normal_gloss;  // CV_16FC4 x, y, z, gloss
};

// Down to 1x1. `default_gloss` fills the gloss channel when the maps have
// no gloss map. Levels beyond `max_size` on a side are dropped (the
// largest level kept becomes level 0), so a 12 MP scan fits a small GPU.
[[nodiscard]] TextureLevels build_texture_levels(const SwatchMaps& maps, float default_gloss,
                                                 int max_size = 16384);

// The sRGB code of a linear value, rounded as GL's conversion does.
[[nodiscard]] std::uint8_t srgb8(float linear);

}  // namespace psrig::preview
