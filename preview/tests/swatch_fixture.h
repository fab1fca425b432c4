#pragma once
// Small swatches with known surfaces for the renderer's tests, built in
// memory: a grid of round bumps (normals known analytically), a coloured
// albedo, and optional gloss and alpha maps.

#include <cmath>
#include <numbers>

#include <opencv2/core.hpp>

#include "psrig/preview/swatch_maps.h"

namespace psrig::preview::testing {

// Bumps of `period` pixels: height h = amplitude * sin(x) * sin(y) in
// pixel units, normal (-dh/dx, -dh/dy, 1) normalised, y up (row 0 on top).
inline SwatchMaps bump_swatch(cv::Size size, float period = 16, float amplitude = 3) {
  SwatchMaps maps;
  maps.albedo.create(size, CV_32FC3);
  maps.normal.create(size, CV_32FC3);
  maps.height.create(size, CV_32FC1);
  const float k = 2 * std::numbers::pi_v<float> / period;
  for (int row = 0; row < size.height; ++row)
    for (int col = 0; col < size.width; ++col) {
      const float x = static_cast<float>(col) + 0.5f;
      const float y = static_cast<float>(size.height - row) - 0.5f;
      const float h = amplitude * std::sin(k * x) * std::sin(k * y);
      const float p = amplitude * k * std::cos(k * x) * std::sin(k * y);
      const float q = amplitude * k * std::sin(k * x) * std::cos(k * y);
      maps.normal.at<cv::Vec3f>(row, col) = cv::normalize(cv::Vec3f(-p, -q, 1));
      maps.height.at<float>(row, col) = h;
      maps.albedo.at<cv::Vec3f>(row, col) = {0.55f + 0.25f * std::sin(0.05f * x),
                                             0.35f + 0.2f * std::cos(0.07f * y), 0.25f};
    }
  maps.pixel_size_mm = 0.05;
  return maps;
}

}  // namespace psrig::preview::testing
