#pragma once
// A folder of images, one (or more) per light, as datasets ship them:
// chrome.0.png … chrome.11.png and chrome.mask.png.

#include <filesystem>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/formats/scan.h"

namespace psrig::calibration {

struct ImageFolder {
  std::vector<std::filesystem::path> images;  // in natural order: 2 before 10
  std::optional<std::filesystem::path> mask;  // the one file whose stem ends in "mask"
};

// The image files of `directory` (.png, .tif, .tiff, .exr, .jpg, .jpeg),
// sorted by name with digit runs compared as numbers, the mask apart.
// bad_input naming the directory when it is not one, holds no images, or
// holds more than one mask.
[[nodiscard]] Result<ImageFolder> list_image_folder(const std::filesystem::path& directory);

// Natural order of file names: "a.2.png" before "a.10.png".
[[nodiscard]] bool natural_less(const std::string& a, const std::string& b);

// An image as linear grey, CV_32F, 0..1 of full scale (the mean of its
// colour channels after decoding `encoding`).
[[nodiscard]] Result<cv::Mat> read_linear_grey(const std::filesystem::path& file,
                                               formats::Encoding encoding);

// A mask file as CV_8U, nonzero = use: grey of any depth, or colour (RGB,
// RGBA or a palette PNG, which OpenCV expands) whose colour channels are
// equal. bad_input naming the file otherwise.
[[nodiscard]] Result<cv::Mat> read_mask(const std::filesystem::path& file,
                                        const std::string& key = "mask");

}  // namespace psrig::calibration
