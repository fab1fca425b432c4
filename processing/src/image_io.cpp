#include "psrig/processing/image_io.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <system_error>

namespace psrig::processing {

Result<cv::Mat> read_image(const std::filesystem::path& file, const std::string& key) {
  std::error_code ec;
  const auto status = std::filesystem::status(file, ec);
  if (!std::filesystem::exists(status))
    return std::unexpected(bad_input(file, key, "no such file"));
  if (!std::filesystem::is_regular_file(status))
    return std::unexpected(bad_input(file, key, "not a regular file"));
  cv::Mat image;
  try {
    image = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    return std::unexpected(bad_input(file, key, std::string("cannot decode: ") + e.what()));
  }
  if (image.empty())
    return std::unexpected(bad_input(
        file, key, "cannot read: not a PNG, TIFF or EXR image, unreadable, or corrupt"));
  return image;
}

Status write_image(const std::filesystem::path& file, const cv::Mat& image,
                   const std::vector<int>& params) {
  try {
    if (!cv::imwrite(file.string(), image, params))
      return std::unexpected(io_error(file, "cannot write image"));
  } catch (const cv::Exception& e) {
    return std::unexpected(io_error(file, std::string("cannot write image: ") + e.what()));
  }
  return {};
}

Status write_vector_exr(const std::filesystem::path& file, const cv::Mat& xyz) {
  cv::Mat zyx;
  cv::cvtColor(xyz, zyx, cv::COLOR_RGB2BGR);
  return write_image(file, zyx, {cv::IMWRITE_EXR_TYPE, cv::IMWRITE_EXR_TYPE_FLOAT});
}

Result<cv::Mat> read_vector_exr(const std::filesystem::path& file, const std::string& key) {
  auto image = read_image(file, key);
  if (!image) return image;
  if (image->type() != CV_32FC3)
    return std::unexpected(bad_input(file, key, "expected a 3-channel 32-bit float image"));
  cv::Mat xyz;
  cv::cvtColor(*image, xyz, cv::COLOR_BGR2RGB);
  return xyz;
}

}  // namespace psrig::processing
