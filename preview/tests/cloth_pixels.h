#pragma once
// What the far-level tests draw and measure a frame of cloth by: one
// frame of a yarn renderer, its pixels in linear light and back, which of
// them are cloth (the cloth's rectangle as the frame shows it, its
// silhouette left out), and the pictures a reviewer asks for.

#include <GLES3/gl3.h>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "psrig/formats/image_io.h"
#include "psrig/preview/knit_view.h"
#include "psrig/preview/offscreen_target.h"
#include "psrig/preview/shading.h"
#include "psrig/preview/texture_levels.h"
#include "psrig/preview/yarn_renderer.h"

namespace psrig::preview::testing {

// One frame of `renderer`'s cloth seen as `view`: 8-bit sRGB (BGR), with
// `samples` multisamples (4 as the knit command's).
inline cv::Mat draw_frame(YarnRenderer& renderer, const KnitView& view, cv::Size size,
                          int samples = 4) {
  auto target = OffscreenTarget::create(size, samples, ColourStorage::srgb);
  EXPECT_TRUE(target) << target.error().describe();
  if (!target) return {};
  (*target)->bind();
  renderer.render(view, size);
  EXPECT_EQ(glGetError(), static_cast<GLenum>(GL_NO_ERROR));
  return (*target)->read();
}

// An 8-bit sRGB frame in linear light, as floats.
inline cv::Mat linear_light(const cv::Mat& frame) {
  cv::Mat out;
  frame.convertTo(out, CV_32F, 1.0 / 255.0);
  out.forEach<cv::Vec3f>([](cv::Vec3f& pixel, const int*) {
    for (int c = 0; c < 3; ++c)
      pixel[c] = srgb_decode(pixel[c]);
  });
  return out;
}

// Linear floats back to 8-bit sRGB codes.
inline cv::Mat srgb_codes(const cv::Mat& linear_frame) {
  cv::Mat out(linear_frame.size(), CV_8UC3);
  for (int row = 0; row < out.rows; ++row)
    for (int col = 0; col < out.cols; ++col) {
      const cv::Vec3f& pixel = linear_frame.at<cv::Vec3f>(row, col);
      for (int c = 0; c < 3; ++c)
        out.at<cv::Vec3b>(row, col)[c] = srgb8(pixel[c]);
    }
  return out;
}

// The cloth's pixels: its rectangle (the bounds' extent in the cloth's
// plane, at mid depth) as the frame shows it, less `margin` pixels all
// round (the silhouette, where the frames' edges differ, left out).
inline cv::Mat cloth_mask(const Eigen::AlignedBox3f& bounds, const KnitView& view, cv::Size size,
                          int margin) {
  const KnitFrame frame = knit_frame(bounds, view, size);
  const float z = bounds.center().z();
  std::vector<cv::Point> corners;
  for (const auto& [x, y] : {std::pair{bounds.min().x(), bounds.min().y()},
                             {bounds.max().x(), bounds.min().y()},
                             {bounds.max().x(), bounds.max().y()},
                             {bounds.min().x(), bounds.max().y()}}) {
    const Eigen::Vector2f p = frame.project({x, y, z}, size);
    corners.emplace_back(static_cast<int>(std::lround(p.x())),
                         static_cast<int>(std::lround(p.y())));
  }
  cv::Mat mask = cv::Mat::zeros(size, CV_8U);
  cv::fillConvexPoly(mask, corners, cv::Scalar(255));
  cv::erode(mask, mask,
            cv::getStructuringElement(cv::MORPH_RECT, {2 * margin + 1, 2 * margin + 1}));
  return mask;
}

// Side by side into `name`.png in the folder environment variable
// `variable` names, when it is set: for a reviewer to look at what a test
// measured. False when it is set and the picture could not be written.
inline bool write_pictures(const char* variable, const std::string& name,
                           const std::vector<cv::Mat>& pictures) {
  const char* dir = std::getenv(variable);
  if (dir == nullptr) return true;
  std::filesystem::create_directories(dir);
  cv::Mat row;
  cv::hconcat(pictures, row);
  return formats::write_image(std::filesystem::path(dir) / (name + ".png"), row).has_value();
}

}  // namespace psrig::preview::testing
