#pragma once
// Image files in and out, with errors that name the file. Colour Mats are
// in OpenCV's BGR channel order, as cv::imread gives them.

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/formats/image_metadata.h"

namespace psrig::formats {

// Reads an image as stored (bit depth and channels unchanged). `key` is the
// scan.json key that named the file, for the error message.
[[nodiscard]] Result<cv::Mat> read_image(const std::filesystem::path& file, const std::string& key);

// Writes; the format follows the extension. PNG: 8/16-bit grey or colour
// go through psrig's libdeflate path, compression level from
// cv::IMWRITE_PNG_COMPRESSION (default 1). EXR: 32-bit float, uncompressed,
// unless params say otherwise.
[[nodiscard]] Status write_image(const std::filesystem::path& file, const cv::Mat& image,
                                 const std::vector<int>& params = {});
// The same, carrying `metadata`: in PNG chunks (8/16-bit grey or colour),
// in EXR header attributes (one or three float or half channels).
[[nodiscard]] Status write_image(const std::filesystem::path& file, const cv::Mat& image,
                                 const std::vector<int>& params, const ImageMetadata& metadata);

// A three-vector image (x, y, z) such as normals, written so that the file's
// R, G, B channels hold x, y, z (cv::imwrite takes BGR).
[[nodiscard]] Status write_vector_exr(const std::filesystem::path& file, const cv::Mat& xyz);
// Reads an image written by write_vector_exr back as (x, y, z).
[[nodiscard]] Result<cv::Mat> read_vector_exr(const std::filesystem::path& file,
                                              const std::string& key);

}  // namespace psrig::formats
