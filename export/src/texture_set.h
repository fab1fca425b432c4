#pragma once
// The textures every export ships, loaded once from a MaterialSource and
// written with the metadata that says their scale and colour space.

#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/export/material_source.h"
#include "psrig/formats/image_metadata.h"

namespace psrig::export_ {

struct TextureSet {
  cv::Mat albedo;  // CV_8UC3, sRGB, OpenCV's BGR
  cv::Mat normal;  // CV_16UC3, (n + 1) / 2, OpenGL convention, BGR
  cv::Mat height;  // CV_16UC1, height_low..height_high; empty without a height map
  double height_low = 0;
  double height_high = 0;
  double height_mean = 0;     // of the heights the map holds, in height units
  cv::Vec3d mean_linear_rgb;  // the albedo's mean, linear, RGB
};

[[nodiscard]] Result<TextureSet> load_textures(const MaterialSource& source);

// What a texture file says about itself (image_metadata.h).
enum class TextureKind { albedo, normal, normal_directx, height, occlusion };
[[nodiscard]] formats::ImageMetadata texture_metadata(const MaterialSource& source,
                                                      const TextureSet& textures, TextureKind kind);

// The normal map with green flipped: DirectX's convention (+Y down).
[[nodiscard]] cv::Mat to_directx(const cv::Mat& normal16);
// 16-bit to 8-bit with rounding (glTF viewers expect 8-bit textures).
[[nodiscard]] cv::Mat to_8bit(const cv::Mat& image16);

// Encodes `image` as a PNG (deflate level 6: exports travel) with metadata.
[[nodiscard]] Result<std::vector<unsigned char>> encode_png(const cv::Mat& image,
                                                            const formats::ImageMetadata& metadata);
// Writes `bytes` to `file`.
[[nodiscard]] Status write_bytes(const std::filesystem::path& file,
                                 const std::vector<unsigned char>& bytes);
// Writes `bytes` to a hidden sibling of `target` and renames it into place:
// the file appears whole or not at all.
[[nodiscard]] Status write_file_atomically(const std::filesystem::path& target,
                                           const std::vector<unsigned char>& bytes);

}  // namespace psrig::export_
