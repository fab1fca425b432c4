#include "psrig/formats/image_io.h"

#include <algorithm>
#include <cctype>
#include <system_error>
#include <utility>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "exr_codec.h"
#include "image_params.h"
#include "png_codec.h"
#include "psrig/base/parallel.h"
#include "psrig/formats/row_writer.h"

namespace psrig::formats {
namespace {

// Float maps barely compress (ZIP saves ~3 % on 12 MP gradients and costs
// ~1 s), so EXR files are written as 32-bit float, uncompressed, unless the
// caller says otherwise.
std::vector<int> with_exr_defaults(std::vector<int> params) {
  const auto has = [&](int key) {
    for (std::size_t i = 0; i + 1 < params.size(); i += 2)
      if (params[i] == key) return true;
    return false;
  };
  if (!has(cv::IMWRITE_EXR_TYPE))
    params.insert(params.end(), {cv::IMWRITE_EXR_TYPE, cv::IMWRITE_EXR_TYPE_FLOAT});
  if (!has(cv::IMWRITE_EXR_COMPRESSION))
    params.insert(params.end(), {cv::IMWRITE_EXR_COMPRESSION, cv::IMWRITE_EXR_COMPRESSION_NO});
  return params;
}

}  // namespace

Result<cv::Mat> read_image(const std::filesystem::path& file, const std::string& key) {
  std::error_code ec;
  const auto status = std::filesystem::status(file, ec);
  if (!std::filesystem::exists(status))
    return std::unexpected(bad_input(file, key, "no such file"));
  if (!std::filesystem::is_regular_file(status))
    return std::unexpected(bad_input(file, key, "not a regular file"));
  cv::Mat image;
  try {
    if (is_png(file)) {
      if (auto fast = png::read(file)) return std::move(*fast);
      if (const auto damage = png::chunk_past_end(file))
        return std::unexpected(bad_input(file, key, "damaged PNG: " + *damage));
    } else if (is_exr(file)) {
      if (auto fast = exr::read(file)) return std::move(*fast);
    }
    image = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    return std::unexpected(bad_input(file, key, std::string("cannot decode: ") + e.what()));
  } catch (const std::exception& e) {  // out of memory
    return std::unexpected(internal_error(file.string() + ": cannot read: " + e.what()));
  }
  if (image.empty())
    return std::unexpected(
        bad_input(file, key, "cannot read: not a PNG, TIFF or EXR image, unreadable, or corrupt"));
  return image;
}

Status write_image(const std::filesystem::path& file, const cv::Mat& image,
                   const std::vector<int>& params) {
  return write_image(file, image, params, ImageMetadata{});
}

Status write_image(const std::filesystem::path& file, const cv::Mat& image,
                   const std::vector<int>& params, const ImageMetadata& metadata) {
  try {
    if (is_png(file) && png::can_write(image))
      return png::write(file, image, png_level(params), metadata);
    if (is_exr(file) && !metadata.empty() && exr::can_write(image))
      return exr::write(file, image, exr_half(params), exr_compression(params), metadata);
    if (!cv::imwrite(file.string(), image, is_exr(file) ? with_exr_defaults(params) : params))
      return std::unexpected(io_error(file, "cannot write image"));
  } catch (const std::exception& e) {
    return std::unexpected(io_error(file, std::string("cannot write image: ") + e.what()));
  }
  return {};
}

Status write_vector_exr(const std::filesystem::path& file, const cv::Mat& xyz) {
  if (xyz.type() != CV_32FC3)
    return std::unexpected(internal_error("write_vector_exr: expected CV_32FC3"));
  // A band at a time in the file's channel order: at 12 MP a reordered copy
  // of the whole image would be 137 MB.
  auto writer = RowWriter::open(file, xyz.size(), CV_32FC3, with_exr_defaults({}), {});
  if (!writer) return std::unexpected(writer.error());
  constexpr int kBandRows = 64;
  cv::Mat zyx;
  for (int top = 0; top < xyz.rows; top += kBandRows) {
    cv::cvtColor(xyz.rowRange(top, std::min(top + kBandRows, xyz.rows)), zyx,
                 cv::COLOR_RGB2BGR);  // cannot throw for CV_32FC3
    if (auto ok = writer->write(zyx); !ok) return ok;
  }
  return writer->finish();
}

Result<cv::Mat> read_vector_exr(const std::filesystem::path& file, const std::string& key) {
  auto image = read_image(file, key);
  if (!image) return image;
  if (image->type() != CV_32FC3)
    return std::unexpected(bad_input(file, key, "expected a 3-channel 32-bit float image"));
  // B, G, R -> x, y, z in place: no second copy of a 12 MP vector image.
  cv::Mat& xyz = *image;
  parallel_chunks(xyz.rows, 64, [&](int begin, int end) {
    for (int r = begin; r < end; ++r) {
      auto* pixel = xyz.ptr<cv::Vec3f>(r);
      for (int c = 0; c < xyz.cols; ++c)
        std::swap(pixel[c][0], pixel[c][2]);
    }
  });
  return image;
}

}  // namespace psrig::formats
