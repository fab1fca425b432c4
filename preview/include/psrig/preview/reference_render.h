#pragma once
// The CPU twin of the swatch renderer for the flat view (scene_view.h):
// each output pixel shaded with shade() from the same texture levels the
// GPU samples, blended over the background, encoded to sRGB. Golden tests
// hold the GLES frame to it pixel by pixel.

#include <expected>
#include <string>

#include <opencv2/core.hpp>

#include "psrig/preview/scene_view.h"
#include "psrig/preview/shading.h"
#include "psrig/preview/texture_levels.h"

namespace psrig::preview {

// Bilinear sample of one level at texture coordinates (u, v), repeating,
// as GL_LINEAR with GL_REPEAT does it (sRGB decoded before filtering).
[[nodiscard]] SurfaceSample sample_level(const TextureLevels& levels, int level, float u, float v);

// The flat view, unrotated and with no margin, drawn at the size of
// texture level `level` so that each pixel lands on one texel. Returns
// CV_8UC3 BGR, top row first; an error for views it does not cover.
[[nodiscard]] std::expected<cv::Mat, std::string> render_flat_reference(
    const TextureLevels& levels, int level, cv::Size2d swatch_extent, const SceneView& view,
    const ShadingParams& params, cv::Vec3f background);

}  // namespace psrig::preview
