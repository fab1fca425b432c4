#include "texture_set.h"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <unistd.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "psrig/formats/image_io.h"
#include "psrig/formats/map_encoding.h"

namespace psrig::export_ {
namespace {

namespace fs = std::filesystem;

std::string number(double v) {
  char text[64];
  std::snprintf(text, sizeof text, "%.9g", v);
  return text;
}

}  // namespace

Result<TextureSet> load_textures(const MaterialSource& source) {
  TextureSet t;
  auto albedo = formats::read_image(source.albedo, "albedo");
  if (!albedo) return std::unexpected(albedo.error());
  if (albedo->type() == CV_8UC1) cv::cvtColor(*albedo, *albedo, cv::COLOR_GRAY2BGR);
  if (albedo->type() == CV_8UC4) cv::cvtColor(*albedo, *albedo, cv::COLOR_BGRA2BGR);
  if (albedo->type() != CV_8UC3)
    return std::unexpected(bad_input(
        source.albedo, "albedo",
        "expected an 8-bit sRGB colour or grey PNG, got " + cv::typeToString(albedo->type())));
  t.albedo = *albedo;
  // The mean colour, linear: what a renderer falls back to without the texture.
  cv::Mat lut(1, 256, CV_32F);
  for (int i = 0; i < 256; ++i) {
    const double c = i / 255.0;
    lut.at<float>(i) =
        static_cast<float>(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
  }
  const cv::Scalar mean_srgb_linear = [&] {
    cv::Mat lin(t.albedo.size(), CV_32FC3);
    t.albedo.forEach<cv::Vec3b>([&](const cv::Vec3b& px, const int* pos) {
      lin.at<cv::Vec3f>(pos[0], pos[1]) = {lut.at<float>(px[0]), lut.at<float>(px[1]),
                                           lut.at<float>(px[2])};
    });
    return cv::mean(lin);
  }();
  t.mean_linear_rgb = {mean_srgb_linear[2], mean_srgb_linear[1], mean_srgb_linear[0]};

  auto normal = formats::read_image(source.normal, "normal");
  if (!normal) return std::unexpected(normal.error());
  if (normal->type() == CV_8UC3) normal->convertTo(*normal, CV_16UC3, 257.0);
  if (normal->type() != CV_16UC3)
    return std::unexpected(bad_input(
        source.normal, "normal",
        "expected an 8- or 16-bit RGB normal map, got " + cv::typeToString(normal->type())));
  if (normal->size() != t.albedo.size())
    return std::unexpected(bad_input(source.normal, "normal", "is not the albedo's size"));
  t.normal = *normal;

  if (!source.height_exr.empty()) {
    auto height = formats::read_image(source.height_exr, "height");
    if (!height) return std::unexpected(height.error());
    if (height->type() != CV_32FC1 || height->size() != t.albedo.size())
      return std::unexpected(bad_input(source.height_exr, "height",
                                       "expected one float channel of the albedo's size"));
    const cv::Mat finite = *height == *height;
    if (cv::countNonZero(finite) > 0) {
      cv::minMaxLoc(*height, &t.height_low, &t.height_high, nullptr, nullptr, finite);
      t.height_mean = cv::mean(*height, finite)[0];
    }
    cv::Mat png = formats::encode_height16(*height, t.height_low, t.height_high);
    png.setTo(0, ~finite);  // holes at the lowest height, as psrig process writes them
    t.height = png;
  } else if (!source.height_png.empty()) {
    if (!source.height_png_range)
      return std::unexpected(bad_input(source.height_png, "height",
                                       "has no known range (report.json height.png_range) and "
                                       "no height.exr is beside it; reprocess the scan"));
    auto height = formats::read_image(source.height_png, "height");
    if (!height) return std::unexpected(height.error());
    if (height->type() != CV_16UC1 || height->size() != t.albedo.size())
      return std::unexpected(bad_input(source.height_png, "height",
                                       "expected a 16-bit grey PNG of the albedo's size"));
    t.height = *height;
    t.height_low = source.height_png_range->first;
    t.height_high = source.height_png_range->second;
    t.height_mean = t.height_low + cv::mean(*height)[0] / 65535.0 * (t.height_high - t.height_low);
  }
  return t;
}

formats::ImageMetadata texture_metadata(const MaterialSource& source, const TextureSet& textures,
                                        TextureKind kind) {
  namespace keys = formats::metadata_keys;
  formats::ImageMetadata m;
  m.pixel_size_mm = source.pixel_size_mm;
  m.colour_space = kind == TextureKind::albedo ? formats::ImageMetadata::ColourSpace::colour
                                               : formats::ImageMetadata::ColourSpace::data;
  if (!source.sample_id.empty()) m.text.emplace_back(keys::kSample, source.sample_id);
  if (!source.scan_time.empty()) m.text.emplace_back(keys::kScanTime, source.scan_time);
  if (source.pixel_size_mm) m.text.emplace_back(keys::kPixelSize, number(*source.pixel_size_mm));
  if (kind == TextureKind::height) {
    m.text.emplace_back(keys::kUnits, source.height_units);
    m.text.emplace_back(keys::kHeightRange,
                        number(textures.height_low) + " " + number(textures.height_high));
  } else if (kind == TextureKind::normal) {
    m.text.emplace_back(keys::kNormalConvention, "OpenGL (+Y up)");
  } else if (kind == TextureKind::normal_directx) {
    m.text.emplace_back(keys::kNormalConvention, "DirectX (+Y down)");
  }
  m.text.emplace_back(keys::kSoftware, "psrig");
  return m;
}

cv::Mat to_directx(const cv::Mat& normal16) {
  return formats::flip_normal_green(normal16);
}

cv::Mat to_8bit(const cv::Mat& image16) {
  cv::Mat out;
  image16.convertTo(out, CV_8U, 1.0 / 257.0);
  return out;
}

Result<std::vector<unsigned char>> encode_png(const cv::Mat& image,
                                              const formats::ImageMetadata& metadata) {
  // Through a file: the metadata-carrying writer is file based.
  char name[] = "/tmp/psrig-export-XXXXXX.png";
  const int fd = ::mkstemps(name, 4);
  if (fd < 0) return std::unexpected(io_error("/tmp", "cannot create a temporary file"));
  ::close(fd);
  const fs::path file = name;
  auto ok = formats::write_image(file, image, {cv::IMWRITE_PNG_COMPRESSION, 6}, metadata);
  std::vector<unsigned char> bytes;
  if (ok) {
    std::ifstream in(file, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  std::error_code ignored;
  fs::remove(file, ignored);
  if (!ok) return std::unexpected(ok.error());
  return bytes;
}

Status write_bytes(const fs::path& file, const std::vector<unsigned char>& bytes) {
  errno = 0;
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out)
    return std::unexpected(
        io_error(file, std::string("cannot write: ") + (errno ? std::strerror(errno) : "failed")));
  return {};
}

Status write_file_atomically(const fs::path& target, const std::vector<unsigned char>& bytes) {
  const fs::path parent = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(parent, ec))
    return std::unexpected(
        bad_input(target, "--out", "its directory does not exist; make it first"));
  const fs::path staging =
      parent / ("." + target.filename().string() + ".partial-" + std::to_string(::getpid()));
  if (auto ok = write_bytes(staging, bytes); !ok) {
    fs::remove(staging, ec);
    return std::unexpected(io_error(target, ok.error().message));
  }
  fs::rename(staging, target, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(staging, ignored);
    return std::unexpected(io_error(target, "cannot rename into place: " + ec.message()));
  }
  return {};
}

}  // namespace psrig::export_
