#include "psrig/preview/swatch_maps.h"

#include <fstream>

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "psrig/formats/image_io.h"
#include "psrig/formats/map_encoding.h"
#include "psrig/formats/scan_layout.h"
#include "psrig/processing/linearise.h"

namespace psrig::preview {
namespace {

namespace fs = std::filesystem;
namespace map_files = formats::map_files;

// Any depth, one or three channels, BGR as OpenCV reads it -> CV_32FC3 RGB.
cv::Mat to_rgb_float(const cv::Mat& image) {
  cv::Mat rgb;
  if (image.channels() == 1)
    cv::cvtColor(image, rgb, cv::COLOR_GRAY2RGB);
  else
    cv::cvtColor(image, rgb, image.channels() == 4 ? cv::COLOR_BGRA2RGB : cv::COLOR_BGR2RGB);
  rgb.convertTo(rgb, CV_32F);
  return rgb;
}

Result<cv::Mat> read_albedo(const fs::path& directory) {
  if (fs::exists(directory / map_files::kAlbedoExr)) {
    auto exr = formats::read_image(directory / map_files::kAlbedoExr, "albedo");
    if (!exr) return std::unexpected(exr.error());
    return to_rgb_float(*exr);
  }
  auto png = formats::read_image(directory / map_files::kAlbedoPng, "albedo");
  if (!png) return std::unexpected(png.error());
  if (png->depth() != CV_8U && png->depth() != CV_16U)
    return std::unexpected(bad_input(directory / map_files::kAlbedoPng, "albedo",
                                     "expected an 8- or 16-bit sRGB image"));
  const double full = png->depth() == CV_8U ? 255 : 65535;
  const processing::CodeLineariser srgb(formats::Encoding::srgb, 0, full, png->depth());
  cv::Mat linear(png->size(), CV_32FC(png->channels()));
  for (int row = 0; row < png->rows; ++row)
    srgb.convert(png->ptr(row), png->cols * png->channels(), linear.ptr<float>(row));
  return to_rgb_float(linear);
}

Result<cv::Mat> read_normals(const fs::path& directory) {
  const fs::path file = directory / map_files::kNormalPng;
  auto png = formats::read_image(file, "normal");
  if (!png) return std::unexpected(png.error());
  if (png->channels() != 3 || (png->depth() != CV_8U && png->depth() != CV_16U))
    return std::unexpected(
        bad_input(file, "normal", "expected an RGB normal map of 8 or 16 bits, (n + 1) / 2"));
  cv::Mat normal = to_rgb_float(*png);
  const double full = png->depth() == CV_8U ? 255.0 : 65535.0;
  normal.convertTo(normal, CV_32F, 2.0 / full, -1.0);
  // Quantised vectors are a little off unit length; facing away is a bad file.
  for (auto it = normal.begin<cv::Vec3f>(); it != normal.end<cv::Vec3f>(); ++it) {
    const float length = static_cast<float>(cv::norm(*it));
    *it = length > 1e-6f ? *it / length : cv::Vec3f(0, 0, 1);
  }
  return normal;
}

// A grey map in [0, 1] (gloss, alpha) if the file is there.
Result<cv::Mat> read_optional_fraction(const fs::path& file, const std::string& key) {
  if (!fs::exists(file)) return cv::Mat();
  auto image = formats::read_image(file, key);
  if (!image) return std::unexpected(image.error());
  if (image->channels() != 1 || (image->depth() != CV_8U && image->depth() != CV_16U))
    return std::unexpected(bad_input(file, key, "expected an 8- or 16-bit grey image"));
  cv::Mat fraction;
  image->convertTo(fraction, CV_32F, image->depth() == CV_8U ? 1.0 / 255 : 1.0 / 65535);
  return fraction;
}

Status read_report(const fs::path& directory, SwatchMaps& maps) {
  const fs::path file = directory / map_files::kReport;
  if (!fs::exists(file)) return {};  // maps from elsewhere: pixel size unknown
  std::ifstream in(file);
  const auto report = nlohmann::json::parse(in, nullptr, false);
  if (report.is_discarded() || !report.is_object())
    return std::unexpected(bad_input(file, "", "not a JSON object"));
  const auto inputs = report.value("inputs", nlohmann::json::object());
  if (const auto size = inputs.find("pixel_size_mm"); size != inputs.end() && !size->is_null()) {
    if (!size->is_number() || size->get<double>() <= 0)
      return std::unexpected(
          bad_input(file, "inputs.pixel_size_mm", "expected a positive number or null"));
    maps.pixel_size_mm = size->get<double>();
  }
  const auto sample = inputs.value("sample", nlohmann::json::object());
  if (sample.is_object() && sample.value("id", nlohmann::json()).is_string())
    maps.sample_id = sample["id"].get<std::string>();
  const auto height = report.value("height", nlohmann::json::object());
  if (height.is_object() && height.value("units", nlohmann::json()).is_string())
    maps.height_units = height["units"].get<std::string>();
  return {};
}

Status check_size(const cv::Mat& image, cv::Size expected, const fs::path& file,
                  const std::string& key) {
  if (image.empty() || image.size() == expected) return {};
  return std::unexpected(bad_input(file, key,
                                   "is " + std::to_string(image.cols) + "x" +
                                       std::to_string(image.rows) + " but the albedo is " +
                                       std::to_string(expected.width) + "x" +
                                       std::to_string(expected.height)));
}

}  // namespace

cv::Size2d SwatchMaps::extent() const {
  const double scale = pixel_size_mm > 0 ? pixel_size_mm : 1.0;
  return {albedo.cols * scale, albedo.rows * scale};
}

Result<SwatchMaps> load_swatch_maps(const fs::path& directory) {
  if (!fs::is_directory(directory))
    return std::unexpected(bad_input(directory, "", "not a maps directory"));
  SwatchMaps maps;
  maps.directory = directory;
  auto albedo = read_albedo(directory);
  if (!albedo) return std::unexpected(albedo.error());
  maps.albedo = std::move(*albedo);
  auto normal = read_normals(directory);
  if (!normal) return std::unexpected(normal.error());
  maps.normal = std::move(*normal);
  if (fs::exists(directory / map_files::kHeightExr)) {
    auto height = formats::read_image(directory / map_files::kHeightExr, "height");
    if (!height) return std::unexpected(height.error());
    if (height->channels() != 1)
      return std::unexpected(
          bad_input(directory / map_files::kHeightExr, "height", "expected one channel"));
    height->convertTo(maps.height, CV_32F);
  }
  auto gloss = read_optional_fraction(directory / swatch_files::kGloss, "gloss");
  if (!gloss) return std::unexpected(gloss.error());
  maps.gloss = std::move(*gloss);
  auto alpha = read_optional_fraction(directory / swatch_files::kAlpha, "alpha");
  if (!alpha) return std::unexpected(alpha.error());
  maps.alpha = std::move(*alpha);

  const cv::Size size = maps.size();
  if (auto ok = check_size(maps.normal, size, directory / map_files::kNormalPng, "normal"); !ok)
    return std::unexpected(ok.error());
  if (auto ok = check_size(maps.height, size, directory / map_files::kHeightExr, "height"); !ok)
    return std::unexpected(ok.error());
  if (auto ok = check_size(maps.gloss, size, directory / swatch_files::kGloss, "gloss"); !ok)
    return std::unexpected(ok.error());
  if (auto ok = check_size(maps.alpha, size, directory / swatch_files::kAlpha, "alpha"); !ok)
    return std::unexpected(ok.error());
  if (auto ok = read_report(directory, maps); !ok) return std::unexpected(ok.error());
  return maps;
}

}  // namespace psrig::preview
