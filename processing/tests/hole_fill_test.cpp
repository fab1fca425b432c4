#include "psrig/processing/hole_fill.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace psrig::processing {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// A tilted plane, which a harmonic fill restores exactly.
cv::Mat plane(int rows, int cols) {
  cv::Mat height(rows, cols, CV_32FC1);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) height.at<float>(r, c) = 0.01f * static_cast<float>(c) - 0.02f * static_cast<float>(r) + 1;
  return height;
}

TEST(HoleFill, SpecksAreFilledFromAroundThemAndHolesStay) {
  const cv::Mat truth = plane(80, 100);
  cv::Mat height = truth.clone();
  cv::Mat fillable(height.size(), CV_8UC1, cv::Scalar(255));
  height.at<float>(10, 10) = kNaN;                               // one pixel
  height(cv::Rect(30, 30, 5, 5)).setTo(kNaN);                    // 25 pixels
  height(cv::Rect(60, 40, 20, 20)).setTo(kNaN);                  // a hole: 400 pixels
  height.at<float>(70, 5) = kNaN;                                // small, but outside the swatch
  fillable.at<std::uint8_t>(70, 5) = 0;
  height(cv::Rect(0, 0, 100, 2)).setTo(kNaN);                    // the mask's outside ...
  fillable(cv::Rect(0, 0, 100, 2)).setTo(0);
  height.at<float>(2, 50) = kNaN;                                // ... and a speck touching it

  EXPECT_EQ(fill_specks(height, fillable, 64), 1 + 25);
  EXPECT_NEAR(height.at<float>(10, 10), truth.at<float>(10, 10), 1e-5);
  EXPECT_LT(cv::norm(height(cv::Rect(30, 30, 5, 5)), truth(cv::Rect(30, 30, 5, 5)), cv::NORM_INF), 1e-4);
  EXPECT_TRUE(std::isnan(height.at<float>(50, 70)));  // the hole
  EXPECT_TRUE(std::isnan(height.at<float>(70, 5)));   // not ours to fill
  EXPECT_TRUE(std::isnan(height.at<float>(2, 50)));   // part of the outside
  EXPECT_TRUE(std::isnan(height.at<float>(0, 0)));
}

TEST(HoleFill, NothingMissingNothingFilled) {
  cv::Mat height = plane(8, 8);
  EXPECT_EQ(fill_specks(height, cv::Mat(8, 8, CV_8UC1, cv::Scalar(255)), 64), 0);
  EXPECT_EQ(cv::norm(height, plane(8, 8), cv::NORM_INF), 0);
}

}  // namespace
}  // namespace psrig::processing
