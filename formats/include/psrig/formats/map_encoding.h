#pragma once
// The maps directory's image encodings (docs/design.md "Maps directory"; names in scan_layout.h),
// as pure functions so their conventions can be checked pixel by pixel.

#include <opencv2/core.hpp>

namespace psrig::formats {

// Linear albedo (CV_32FC1/C3) -> 8-bit sRGB, clamped to [0, 1].
[[nodiscard]] cv::Mat encode_albedo_srgb8(const cv::Mat& albedo);

// Gradients -> tangent-space normal map, OpenGL convention (+Y up, as glTF):
// file RGB = (n + 1) / 2 at 16 bits. Returned in OpenCV's BGR order, ready
// for cv::imwrite.
[[nodiscard]] cv::Mat encode_normal16(const cv::Mat& p, const cv::Mat& q);

// An encoded normal map (8- or 16-bit, BGR) in the other convention: green
// mirrored, OpenGL (+Y up) <-> DirectX (+Y down), as Substance and Unreal
// expect by default.
[[nodiscard]] cv::Mat flip_normal_green(const cv::Mat& normal);

// A normal map made anywhere -> gradients p, q (CV_32F), the inverse of
// encode_normal16 and more: 8- or 16-bit RGB(A) PNGs hold (n + 1) / 2 per
// channel, float images (EXR, TIFF) hold n itself; colour Mats in OpenCV's
// BGR(A) order, as cv::imread gives them. OpenGL convention (green up)
// unless green_down (DirectX). A pixel with n_z <= 0.01 (a zero, or
// background, pixel decodes to n_z = -1), a non-finite channel, or alpha 0
// has no gradient: p = q = NaN, which the masked integrator leaves out.
// Returns an empty pair for a Mat that is not 3 or 4 channels of 8-bit,
// 16-bit or 32-bit float.
struct DecodedGradients {
  cv::Mat p;
  cv::Mat q;
};
[[nodiscard]] DecodedGradients decode_normal_map(const cv::Mat& image, bool green_down = false);

// Height -> 16-bit grey, `low` to 0 and `high` to 65535.
[[nodiscard]] cv::Mat encode_height16(const cv::Mat& height, double low, double high);

}  // namespace psrig::formats
