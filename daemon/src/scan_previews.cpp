#include "scan_previews.h"

#include <algorithm>
#include <cmath>
#include <system_error>
#include <thread>
#include <unistd.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "psrig/formats/scan_layout.h"

namespace psrig::daemon {

namespace fs = std::filesystem;

namespace {

constexpr int kWidth = 320;
constexpr int kHeight = 240;
// The raking light: from the upper left of the picture, 30° above the
// swatch. Shading is divided by its value on a flat patch (sin 30°), so
// flat cloth keeps its albedo and slopes facing the light brighten.
constexpr double kLightAzimuthDeg = 135;
constexpr double kLightElevationDeg = 30;
constexpr double kAmbient = 0.12;

// The middle 4:3 of `image`, shrunk by area averaging to `size`.
cv::Mat cover(const cv::Mat& image, cv::Size size) {
  const double aspect = static_cast<double>(size.width) / size.height;
  cv::Rect crop(0, 0, image.cols, image.rows);
  if (image.cols > image.rows * aspect) {
    crop.width = static_cast<int>(std::lround(image.rows * aspect));
    crop.x = (image.cols - crop.width) / 2;
  } else {
    crop.height = static_cast<int>(std::lround(image.cols / aspect));
    crop.y = (image.rows - crop.height) / 2;
  }
  cv::Mat out;
  const bool shrinking = crop.width >= size.width;
  cv::resize(image(crop), out, size, 0, 0, shrinking ? cv::INTER_AREA : cv::INTER_CUBIC);
  return out;
}

// 8-bit sRGB (any channel count) → linear float BGR in [0, 1].
cv::Mat linear_bgr(const cv::Mat& image) {
  cv::Mat bgr;
  if (image.channels() == 1)
    cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
  else if (image.channels() == 4)
    cv::cvtColor(image, bgr, cv::COLOR_BGRA2BGR);
  else
    bgr = image;
  cv::Mat eight;
  if (bgr.depth() == CV_16U)
    bgr.convertTo(eight, CV_8U, 1.0 / 257);
  else
    eight = bgr;
  cv::Mat lut(1, 256, CV_32F);
  for (int i = 0; i < 256; ++i) {
    const double c = i / 255.0;
    lut.at<float>(i) =
        static_cast<float>(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
  }
  cv::Mat linear;
  cv::LUT(eight, lut, linear);
  return linear;
}

cv::Mat srgb8(const cv::Mat& linear) {
  cv::Mat out(linear.size(), CV_8UC3);
  linear.forEach<cv::Vec3f>([&](const cv::Vec3f& value, const int* at) {
    cv::Vec3b& o = out.at<cv::Vec3b>(at[0], at[1]);
    for (int c = 0; c < 3; ++c) {
      const double v = std::clamp(static_cast<double>(value[c]), 0.0, 1.0);
      const double e = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1 / 2.4) - 0.055;
      o[c] = cv::saturate_cast<std::uint8_t>(e * 255 + 0.5);
    }
  });
  return out;
}

// albedo × (ambient + raking light), at twice the thumbnail's size, then
// shrunk: shading a shrunk normal map would lose the yarns.
cv::Mat relight(const cv::Mat& albedo_image, const cv::Mat& normal_image) {
  const cv::Size work(kWidth * 2, kHeight * 2);
  const cv::Mat albedo = cover(linear_bgr(albedo_image), work);
  cv::Mat normal;
  normal_image.convertTo(normal, CV_32F, normal_image.depth() == CV_16U ? 1.0 / 65535 : 1.0 / 255);
  normal = cover(normal, work);
  const double az = kLightAzimuthDeg * CV_PI / 180;
  const double el = kLightElevationDeg * CV_PI / 180;
  // Picture axes: x right, y up (the normal map's OpenGL convention).
  const cv::Vec3d light(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
  cv::Mat lit(work, CV_32FC3);
  lit.forEach<cv::Vec3f>([&](cv::Vec3f& out, const int* at) {
    const auto& c = normal.at<cv::Vec3f>(at[0], at[1]);  // B, G, R = z, y, x
    cv::Vec3d n(2.0 * c[2] - 1, 2.0 * c[1] - 1, 2.0 * c[0] - 1);
    const double length = cv::norm(n);
    const double facing = length > 0.1 ? std::max(0.0, n.dot(light) / length) : 0.0;
    const double shade = kAmbient + (1 - kAmbient) * facing / light[2];
    const auto& a = albedo.at<cv::Vec3f>(at[0], at[1]);
    out = cv::Vec3f(static_cast<float>(a[0] * shade), static_cast<float>(a[1] * shade),
                    static_cast<float>(a[2] * shade));
  });
  cv::Mat small;
  cv::resize(lit, small, cv::Size(kWidth, kHeight), 0, 0, cv::INTER_AREA);
  return srgb8(small);
}

bool newer_than(const fs::path& file, const fs::path& reference) {
  std::error_code a;
  std::error_code b;
  const auto made = fs::last_write_time(file, a);
  const auto source = fs::last_write_time(reference, b);
  return !a && (b || made >= source);
}

Result<cv::Mat> read(const fs::path& file, int flags) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec))
    return std::unexpected(bad_input(file, "", "the scan has no " + file.filename().string()));
  cv::Mat image = cv::imread(file.string(), flags);
  if (image.empty()) return std::unexpected(io_error(file, "cannot read it as an image"));
  return image;
}

}  // namespace

const char* file_name(ScanPreview preview) {
  return preview == ScanPreview::thumbnail ? "thumbnail.png" : "relit.png";
}

Result<fs::path> scan_preview(const fs::path& maps_directory, ScanPreview preview) {
  const fs::path folder = maps_directory.parent_path() / "previews";
  const fs::path file = folder / file_name(preview);
  if (newer_than(file, maps_directory / formats::map_files::kReport)) return file;

  auto albedo = read(maps_directory / formats::map_files::kAlbedoPng, cv::IMREAD_UNCHANGED);
  if (!albedo) return std::unexpected(albedo.error());
  cv::Mat picture;
  if (preview == ScanPreview::thumbnail) {
    cv::Mat bgr = albedo->channels() == 1 ? cv::Mat() : *albedo;
    if (albedo->channels() == 1) cv::cvtColor(*albedo, bgr, cv::COLOR_GRAY2BGR);
    if (bgr.channels() == 4) cv::cvtColor(bgr, bgr, cv::COLOR_BGRA2BGR);
    if (bgr.depth() == CV_16U) bgr.convertTo(bgr, CV_8U, 1.0 / 257);
    picture = cover(bgr, cv::Size(kWidth, kHeight));  // sRGB averaged: close enough at this size
  } else {
    auto normal = read(maps_directory / formats::map_files::kNormalPng, cv::IMREAD_UNCHANGED);
    if (!normal) return std::unexpected(normal.error());
    if (normal->channels() != 3 || normal->size() != albedo->size())
      return std::unexpected(io_error(maps_directory / formats::map_files::kNormalPng,
                                      "not an RGB normal map the albedo's size"));
    picture = relight(*albedo, *normal);
  }

  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec) return std::unexpected(io_error(folder, "cannot create: " + ec.message()));
  // Two requests may make it at once: each writes its own file, the last
  // rename wins, both are whole.
  const fs::path temporary =
      folder / ("." + std::string(file_name(preview)) + "." + std::to_string(::getpid()) + "." +
                std::to_string(std::hash<std::thread::id>{}(std::this_thread::get_id())) + ".png");
  if (!cv::imwrite(temporary.string(), picture)) {
    fs::remove(temporary, ec);
    return std::unexpected(io_error(temporary, "cannot write the preview"));
  }
  fs::rename(temporary, file, ec);
  if (ec) {
    fs::remove(temporary, ec);
    return std::unexpected(io_error(file, "cannot move the preview into place: " + ec.message()));
  }
  return file;
}

}  // namespace psrig::daemon
