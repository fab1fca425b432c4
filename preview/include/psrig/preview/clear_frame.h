#pragma once
// The first step of every frame: the viewport set and the bound framebuffer
// cleared (colour and depth) to the background, a linear colour, sRGB-encoded
// here where the framebuffer does not encode on write. For both renderers and
// the kiosk's screen between scans.

#include <opencv2/core.hpp>

namespace psrig::preview {

void clear_frame(cv::Vec3f linear, bool encode_srgb, cv::Size viewport);

}  // namespace psrig::preview
