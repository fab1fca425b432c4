// Removing the low-frequency bend: a flat textured swatch with a known
// low-order bend comes out flat, and its yarn-scale relief comes out whole.

#include "psrig/processing/flatten.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace psrig::processing {
namespace {

constexpr double kPixelMm = 0.025;  // the simulated rig's

// Knit-like relief in mm: stitches 1.6 mm wide, rows 1.2 mm, yarn ridges of
// 0.4 mm, amplitudes 0.05-0.15 mm.
cv::Mat relief(int w, int h) {
  cv::Mat z(h, w, CV_32F);
  for (int row = 0; row < h; ++row)
    for (int col = 0; col < w; ++col) {
      const double x = col * kPixelMm;
      const double y = (h - 1 - row) * kPixelMm;
      const double two_pi = 2.0 * std::numbers::pi;
      z.at<float>(row, col) = static_cast<float>(
          0.15 * std::sin(two_pi * x / 1.6) * std::cos(two_pi * y / 1.2) +
          0.05 * std::sin(two_pi * (x + 0.5 * y) / 0.4) + 0.08 * std::cos(two_pi * y / 2.5));
    }
  return z;
}

// A bowl tilted and twisted, 0.8 mm deep across the swatch, plus a gentle
// cubic: what light-model errors leave.
cv::Mat bend(int w, int h) {
  cv::Mat z(h, w, CV_32F);
  for (int row = 0; row < h; ++row)
    for (int col = 0; col < w; ++col) {
      const double x = (col - 0.5 * w) / (0.5 * w);
      const double y = (0.5 * h - row) / (0.5 * h);
      z.at<float>(row, col) = static_cast<float>(0.5 * x * x + 0.3 * y * y - 0.2 * x * y + 0.1 * x -
                                                 0.15 * y + 0.08 * x * x * x);
    }
  return z;
}

// The relief's fine content: the height less its Gaussian blur at 1 mm.
cv::Mat high_pass(const cv::Mat& z) {
  cv::Mat blurred;
  const double sigma = 1.0 / kPixelMm;
  cv::GaussianBlur(z, blurred, cv::Size(), sigma, sigma, cv::BORDER_REFLECT);
  return z - blurred;
}

double rms_about_mean(const cv::Mat& m, const cv::Mat& mask = {}) {
  cv::Scalar mean;
  cv::Scalar deviation;
  cv::meanStdDev(m, mean, deviation, mask);
  return deviation[0];
}

TEST(Flatten, ABentFlatSwatchComesOutFlatWithItsReliefWhole) {
  const int w = 960;  // 24 x 18 mm
  const int h = 720;
  const cv::Mat truth = relief(w, h);
  const cv::Mat added = bend(w, h);
  cv::Mat height = truth + added;
  const auto removed = remove_bend(height, 10.0 / kPixelMm);
  ASSERT_TRUE(removed.has_value()) << removed.error().describe();

  double low = 0;
  double high = 0;
  cv::minMaxLoc(added, &low, &high);
  const double residual_bend = rms_about_mean(height - truth);
  const double before = rms_about_mean(added);
  // The relief's fine content, away from the borders the 1 mm blur reflects at.
  const cv::Rect inner(80, 80, w - 160, h - 160);
  const cv::Mat fine_truth = high_pass(truth)(inner);
  const cv::Mat fine_after = high_pass(height)(inner);
  const double fine_error = rms_about_mean(fine_after - fine_truth);
  const double fine_ratio = rms_about_mean(fine_after) / rms_about_mean(fine_truth);
  std::printf(
      "  [measured] bend %.3f mm p-v (rms %.3f); removed %.3f mm p-v (rms %.3f); left %.4f mm "
      "rms; relief rms %.3f mm; high-pass content kept %.4f, error %.2g mm rms\n",
      high - low, before, removed->peak_to_valley, removed->rms, residual_bend,
      rms_about_mean(truth), fine_ratio, fine_error);
  // Flat: what is left of the bend is under 3 % of it (and of the relief).
  EXPECT_LT(residual_bend, 0.03 * before);
  EXPECT_NEAR(removed->peak_to_valley, high - low, 0.05 * (high - low));
  // The yarn-scale relief is kept to 1 %.
  EXPECT_NEAR(fine_ratio, 1.0, 0.01);
  EXPECT_LT(fine_error, 0.01 * rms_about_mean(fine_truth));
}

TEST(Flatten, HolesAndBordersStayAsTheyAre) {
  const int w = 400;
  const int h = 300;
  cv::Mat height = relief(w, h) + bend(w, h);
  cv::Mat hole(h, w, CV_8U, cv::Scalar(0));
  cv::circle(hole, cv::Point(200, 150), 60, cv::Scalar(255), cv::FILLED);
  height.setTo(std::numeric_limits<float>::quiet_NaN(), hole);
  const cv::Mat truth = relief(w, h);
  const auto removed = remove_bend(height, 10.0 / kPixelMm);
  ASSERT_TRUE(removed.has_value());
  EXPECT_TRUE(std::isnan(height.at<float>(150, 200)));
  EXPECT_TRUE(std::isnan(removed->bend.at<float>(150, 200)));
  cv::Mat difference = height - truth;
  const cv::Mat outside = hole == 0;
  // A 10 x 7.5 mm swatch with a 3 mm hole, under a 10 mm cut-off: what is
  // left of the bend, measured 5 % of it, mostly around the hole.
  const double left = rms_about_mean(difference, outside);
  std::printf("  [measured] with a hole: left %.4f mm rms of a %.3f mm rms bend\n", left,
              rms_about_mean(bend(w, h)));
  EXPECT_LT(left, 0.08 * rms_about_mean(bend(w, h)));
}

// Without the bend returned, the same height and the same sizes.
TEST(Flatten, WithoutTheBendReturnedTheHeightIsTheSame) {
  cv::Mat height = relief(300, 200) + bend(300, 200);
  height.at<float>(50, 60) = std::numeric_limits<float>::quiet_NaN();
  height.at<float>(70, 80) = std::numeric_limits<float>::infinity();
  cv::Mat lean = height.clone();
  const auto kept = remove_bend(height, 10.0 / kPixelMm);
  const auto sizes_only = remove_bend(lean, 10.0 / kPixelMm, false);
  ASSERT_TRUE(kept && sizes_only);
  EXPECT_TRUE(sizes_only->bend.empty());
  EXPECT_EQ(cv::norm(height == height, lean == lean, cv::NORM_INF), 0);  // NaN where it was
  const cv::Mat finite = (height == height) & (cv::abs(height) < 1e30);
  EXPECT_EQ(cv::norm(height, lean, cv::NORM_INF, finite), 0);
  EXPECT_EQ(kept->peak_to_valley, sizes_only->peak_to_valley);
  EXPECT_EQ(kept->rms, sizes_only->rms);
}

TEST(Flatten, RejectsBadInputs) {
  cv::Mat height(10, 10, CV_32F, cv::Scalar(0));
  EXPECT_FALSE(remove_bend(height, 0.0));
  EXPECT_FALSE(remove_bend(height, -1.0));
  cv::Mat doubles(10, 10, CV_64F, cv::Scalar(0));
  EXPECT_FALSE(remove_bend(doubles, 5.0));
  cv::Mat all_nan(10, 10, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  const auto removed = remove_bend(all_nan, 5.0);
  ASSERT_TRUE(removed.has_value());
  EXPECT_EQ(removed->peak_to_valley, 0.0);
}

}  // namespace
}  // namespace psrig::processing
