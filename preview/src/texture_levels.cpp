#include "psrig/preview/texture_levels.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "psrig/preview/shading.h"

namespace psrig::preview {
namespace {

// Linear CV_32FC4 -> sRGB-coded CV_8UC4 (alpha stays linear).
cv::Mat encode_albedo_level(const cv::Mat& linear) {
  cv::Mat coded(linear.size(), CV_8UC4);
  for (int row = 0; row < linear.rows; ++row) {
    const auto* in = linear.ptr<cv::Vec4f>(row);
    auto* out = coded.ptr<cv::Vec4b>(row);
    for (int col = 0; col < linear.cols; ++col) {
      for (int c = 0; c < 3; ++c)
        out[col][c] = srgb8(in[col][c]);
      out[col][3] = cv::saturate_cast<std::uint8_t>(std::lround(in[col][3] * 255.0f));
    }
  }
  return coded;
}

cv::Mat half_level(const cv::Mat& level) {
  const cv::Size size(std::max(level.cols / 2, 1), std::max(level.rows / 2, 1));
  cv::Mat smaller;
  // INTER_AREA is the 2x2 box filter on even sizes and the exact area
  // average on odd ones.
  cv::resize(level, smaller, size, 0, 0, cv::INTER_AREA);
  return smaller;
}

cv::Mat with_fourth_channel(const cv::Mat& rgb, const cv::Mat& fourth, float fill) {
  std::vector<cv::Mat> planes;
  cv::split(rgb, planes);
  planes.push_back(fourth.empty() ? cv::Mat(rgb.size(), CV_32F, cv::Scalar(fill)) : fourth);
  cv::Mat rgba;
  cv::merge(planes, rgba);
  cv::flip(rgba, rgba, 0);  // bottom row first (GL's t runs up)
  return rgba;
}

}  // namespace

std::uint8_t srgb8(float linear) {
  return static_cast<std::uint8_t>(std::lround(srgb_encode(linear) * 255.0f));
}

TextureLevels build_texture_levels(const SwatchMaps& maps, float default_gloss, int max_size) {
  cv::Mat albedo = with_fourth_channel(maps.albedo, maps.alpha, 1.0f);
  cv::Mat normal = with_fourth_channel(maps.normal, maps.gloss, default_gloss);
  while (albedo.cols > max_size || albedo.rows > max_size) {
    albedo = half_level(albedo);
    normal = half_level(normal);
  }
  TextureLevels levels;
  for (;;) {
    levels.albedo_alpha.push_back(encode_albedo_level(albedo));
    cv::Mat half;
    normal.convertTo(half, CV_16F);
    levels.normal_gloss.push_back(half);
    if (albedo.cols == 1 && albedo.rows == 1) break;
    albedo = half_level(albedo);
    normal = half_level(normal);
  }
  return levels;
}

}  // namespace psrig::preview
