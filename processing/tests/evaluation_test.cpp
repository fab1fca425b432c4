// The report's statistics against their definitions, computed the slow way.

#include "psrig/processing/evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "psrig/base/parallel.h"

namespace psrig::processing {
namespace {

// Values with ties, NaN and infinities, and a selection of about two thirds.
struct Sample {
  cv::Mat values = cv::Mat(611, 397, CV_32F);
  cv::Mat select = cv::Mat(611, 397, CV_8U);
  Sample() {
    cv::RNG rng(7);
    rng.fill(values, cv::RNG::NORMAL, 0.3, 2.0);
    for (int r = 0; r < values.rows; ++r)
      for (int c = 0; c < values.cols; ++c) {
        if ((r * 7 + c) % 97 == 0) values.at<float>(r, c) = 1.5F;  // ties
        if ((r + c) % 211 == 0) values.at<float>(r, c) = std::numeric_limits<float>::quiet_NaN();
        if ((r + 3 * c) % 307 == 0) values.at<float>(r, c) = std::numeric_limits<float>::infinity();
        select.at<std::uint8_t>(r, c) = (r * 13 + c * 5) % 3 != 0 ? 255 : 0;
      }
  }
  // The selected finite values, sorted.
  [[nodiscard]] std::vector<float> chosen() const {
    std::vector<float> out;
    for (int r = 0; r < values.rows; ++r)
      for (int c = 0; c < values.cols; ++c)
        if (select.at<std::uint8_t>(r, c) && std::isfinite(values.at<float>(r, c)))
          out.push_back(values.at<float>(r, c));
    std::sort(out.begin(), out.end());
    return out;
  }
};

TEST(Evaluation, DescribeGivesTheQuantilesAndMomentsOfTheSelectedFiniteValues) {
  const Sample sample;
  const std::vector<float> sorted = sample.chosen();
  const double n = static_cast<double>(sorted.size());
  double sum = 0, squares = 0;
  for (float v : sorted) {
    sum += v;
    squares += static_cast<double>(v) * v;
  }
  const Distribution d = describe(sample.values, sample.select);
  EXPECT_EQ(d.count, sorted.size());
  EXPECT_EQ(d.median, sorted[static_cast<std::size_t>(std::llround(0.5 * (n - 1)))]);
  EXPECT_EQ(d.p95, sorted[static_cast<std::size_t>(std::llround(0.95 * (n - 1)))]);
  EXPECT_EQ(d.max, sorted.back());
  EXPECT_NEAR(d.mean, sum / n, 1e-12);
  EXPECT_NEAR(d.rms, std::sqrt(squares / n), 1e-12);
  // The moments alone: the same moments, no quantiles.
  const Distribution m = describe_moments(sample.values, sample.select);
  EXPECT_EQ(m.count, d.count);
  EXPECT_EQ(m.mean, d.mean);
  EXPECT_EQ(m.rms, d.rms);
  EXPECT_EQ(m.max, d.max);
  EXPECT_EQ(m.median, 0);
  EXPECT_EQ(m.p95, 0);
}

TEST(Evaluation, HeightRmsErrorIsTheRmsOfTheDifferenceAboutItsMean) {
  const Sample sample;
  cv::Mat truth(sample.values.size(), CV_32F);
  cv::RNG(8).fill(truth, cv::RNG::UNIFORM, -1, 1);
  const cv::Mat difference = sample.values - truth;
  const Distribution d = describe(difference, sample.select);
  EXPECT_EQ(height_rms_error(sample.values, truth, sample.select),
            std::sqrt(std::max(0.0, d.rms * d.rms - d.mean * d.mean)));
}

// The angle between the normals of (p, q) and the truth: atan2 of their
// cross product's length and their dot product, bit for bit as the C
// library's atan2f gives it, for every case: tiny and large angles, beyond
// 90 degrees, normals at right angles, NaN.
TEST(Evaluation, AngularErrorIsTheLibrarysAtan2ToTheBit) {
  cv::Mat p(97, 131, CV_32F), q(97, 131, CV_32F), truth(97, 131, CV_32FC3);
  cv::RNG rng(11);
  for (int r = 0; r < p.rows; ++r)
    for (int c = 0; c < p.cols; ++c) {
      const int kind = (r * p.cols + c) % 5;
      const double scale = kind == 0 ? 1e-4 : kind == 1 ? 1.0 : kind == 2 ? 30.0 : 1e-7;
      p.at<float>(r, c) = static_cast<float>(rng.uniform(-1.0, 1.0) * scale);
      q.at<float>(r, c) = static_cast<float>(rng.uniform(-1.0, 1.0) * scale);
      cv::Vec3f t(static_cast<float>(rng.uniform(-0.3, 0.3)),
                  static_cast<float>(rng.uniform(-0.3, 0.3)), 1.0F);
      if (kind == 3) t = cv::Vec3f(1, 0, 0);  // at right angles, or beyond
      if (kind == 4) t = -t;                  // beyond 90 degrees
      truth.at<cv::Vec3f>(r, c) = t / cv::norm(t);
    }
  p.at<float>(3, 4) = std::numeric_limits<float>::quiet_NaN();
  const cv::Mat error = angular_error_deg(p, q, truth);
  for (int r = 0; r < p.rows; ++r)
    for (int c = 0; c < p.cols; ++c) {
      const float nx = -p.at<float>(r, c), ny = -q.at<float>(r, c), nz = 1;
      const cv::Vec3f t = truth.at<cv::Vec3f>(r, c);
      const float cx = ny * t[2] - nz * t[1], cy = nz * t[0] - nx * t[2],
                  cz = nx * t[1] - ny * t[0];
      const float angle =
          std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), nx * t[0] + ny * t[1] + nz * t[2]);
      const float expected = angle * static_cast<float>(180 / std::numbers::pi);
      const float got = error.at<float>(r, c);
      ASSERT_TRUE(std::memcmp(&expected, &got, sizeof got) == 0)
          << "at " << r << ", " << c << ": " << got << " against " << expected;
    }
}

TEST(Evaluation, TheSameWhateverTheThreadCount) {
  if (std::thread::hardware_concurrency() < 2)
    GTEST_SKIP() << "one hardware thread: nothing to compare";
  const Sample sample;
  set_thread_count(1);
  const Distribution one = describe(sample.values, sample.select);
  set_thread_count(2);
  const Distribution two = describe(sample.values, sample.select);
  set_thread_count(0);
  EXPECT_EQ(one.mean, two.mean);
  EXPECT_EQ(one.rms, two.rms);
  EXPECT_EQ(one.median, two.median);
  EXPECT_EQ(one.p95, two.p95);
}

}  // namespace
}  // namespace psrig::processing
