#pragma once
// The maps directory's image encodings (docs/design.md "Maps directory"; names in scan_layout.h),
// as pure functions so their conventions can be checked pixel by pixel.

#include <opencv2/core.hpp>

namespace psrig::processing {

// Linear albedo (CV_32FC1/C3) -> 8-bit sRGB, clamped to [0, 1].
[[nodiscard]] cv::Mat encode_albedo_srgb8(const cv::Mat& albedo);

// Gradients -> tangent-space normal map, OpenGL convention (+Y up, as glTF):
// file RGB = (n + 1) / 2 at 16 bits. Returned in OpenCV's BGR order, ready
// for cv::imwrite.
[[nodiscard]] cv::Mat encode_normal16(const cv::Mat& p, const cv::Mat& q);

// Height -> 16-bit grey, `low` to 0 and `high` to 65535.
[[nodiscard]] cv::Mat encode_height16(const cv::Mat& height, double low, double high);

// Solve flags -> CV_8U, 255 where the pixel is valid, 0 elsewhere.
[[nodiscard]] cv::Mat encode_valid_mask(const cv::Mat& flags);

}  // namespace psrig::processing
