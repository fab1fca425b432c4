#pragma once
// EXR files with header attributes, through OpenEXR itself: OpenCV's
// writer has no way to add attributes. Pixels as cv::imwrite writes them
// (grey as Y; OpenCV's BGR as R, G, B), uncompressed.

#include <filesystem>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/formats/image_metadata.h"

namespace psrig::formats::exr {

// Whether write() takes this image: CV_32F, one or three channels.
[[nodiscard]] bool can_write(const cv::Mat& image);

// Writes 32-bit float, or half when `half`, compressed by `compression`
// (cv::ImwriteEXRCompressionFlags, whose values are OpenEXR's own), with
// `metadata` as attributes: the text as string attributes under their
// keywords, the pixel size as the standard xDensity (pixels per inch) and
// psrig:pixel_size_mm.
[[nodiscard]] Status write(const std::filesystem::path& file, const cv::Mat& image, bool half,
                           int compression, const ImageMetadata& metadata);

}  // namespace psrig::formats::exr
