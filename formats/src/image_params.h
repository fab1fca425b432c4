#pragma once
// What write_image and RowWriter read from a file's name and OpenCV-style
// params: the format, and its compression and sample type.

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

namespace psrig::formats {

inline bool has_extension(const std::filesystem::path& file, const std::string& wanted) {
  std::string extension = file.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return extension == wanted;
}
inline bool is_png(const std::filesystem::path& file) {
  return has_extension(file, ".png");
}

// OpenCV's PNG compression parameter, if given; psrig's default is the
// fastest level that still compresses.
inline int png_level(const std::vector<int>& params) {
  for (std::size_t i = 0; i + 1 < params.size(); i += 2)
    if (params[i] == cv::IMWRITE_PNG_COMPRESSION) return params[i + 1];
  return 1;
}

inline bool is_exr(const std::filesystem::path& file) {
  return has_extension(file, ".exr");
}

// The caller's EXR compression, else image_io's default (none: image_io.cpp,
// with_exr_defaults).
inline int exr_compression(const std::vector<int>& params) {
  for (std::size_t i = 0; i + 1 < params.size(); i += 2)
    if (params[i] == cv::IMWRITE_EXR_COMPRESSION) return params[i + 1];
  return cv::IMWRITE_EXR_COMPRESSION_NO;
}

inline bool exr_half(const std::vector<int>& params) {
  for (std::size_t i = 0; i + 1 < params.size(); i += 2)
    if (params[i] == cv::IMWRITE_EXR_TYPE) return params[i + 1] == cv::IMWRITE_EXR_TYPE_HALF;
  return false;
}

}  // namespace psrig::formats
