// Outlier rejection (--reject) on glossy surfaces, against plain least
// squares and the naive rule it must beat: per pixel, drop the darkest
// quarter and the brightest sixth of the values (n / 4 and n / 6, rounded
// down: 2 and 1 of 8, 3 and 2 of 12, 16 and 10 of 64, 24 and 16 of 96), then
// least squares. Every figure in this file is SYNTHETIC: Lambertian plus a
// Blinn-Phong lobe, cast shadows and noise, with known normals (the real
// captures are in real_data_test.cpp). Measured figures are in the comments.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <string>

#include <gtest/gtest.h>

#include "psrig/processing/woodham.h"
#include "synthetic_scene.h"

namespace psrig::processing {
namespace {

// The naive rule, straight from the frames (no dark, no flats, intensity 1):
// unit normals, CV_32FC3, (0, 0, 0) where it has no answer.
cv::Mat naive_rule_normals(const Scan& scan) {
  const int lights = static_cast<int>(scan.frames.size());
  const int channels = scan.channels();
  const cv::Size size = scan.size();
  cv::Mat normals(size, CV_32FC3, cv::Scalar(0, 0, 0));
  std::vector<cv::Mat> frames;
  for (const auto& f : scan.frames) {
    cv::Mat linear;
    f.convertTo(linear, CV_MAKETYPE(CV_32F, channels), 1.0 / scan.white_level);
    frames.push_back(linear);
  }
  std::vector<std::pair<double, int>> values(static_cast<std::size_t>(lights));
  const auto& d = scan.description.lights;
  for (int r = 0; r < size.height; ++r) {
    for (int c = 0; c < size.width; ++c) {
      for (int k = 0; k < lights; ++k) {
        const float* m = frames[k].ptr<float>(r) + c * channels;
        double sum = 0;
        for (int ch = 0; ch < channels; ++ch)
          sum += m[ch];
        values[k] = {sum / channels, k};
      }
      std::sort(values.begin(), values.end());
      cv::Matx33d a = cv::Matx33d::zeros();
      cv::Vec3d b(0, 0, 0);
      for (int j = lights / 4; j < lights - lights / 6; ++j) {
        const cv::Vec3d l = d[values[j].second].direction;
        a += l * l.t();
        b += l * values[j].first;
      }
      cv::Vec3d t;
      if (!cv::solve(a, b, t, cv::DECOMP_CHOLESKY) || !(t[2] > 0)) continue;
      t /= cv::norm(t);
      normals.at<cv::Vec3f>(r, c) = cv::Vec3f(t);
    }
  }
  return normals;
}

cv::Mat solved(const cv::Mat& flags) {
  cv::Mat unsolved;
  cv::bitwise_and(flags, cv::Scalar(kOutsideMask | kLowSignal | kNoSolution), unsolved);
  return unsolved == 0;
}

struct Errors {
  double plain = 0, naive = 0, robust = 0;
};

// Mean angular errors (degrees) of the three over the pixels all three solve.
Errors compare(const Scan& scan, const cv::Mat& truth) {
  auto plain = solve(scan);
  auto robust = solve(scan, {.reject_outliers = true});
  EXPECT_TRUE(plain && robust);
  if (!plain || !robust) return {};
  const cv::Mat naive = naive_rule_normals(scan);
  std::vector<cv::Mat> naive_z;
  cv::split(naive, naive_z);
  const cv::Mat select = solved(plain->flags) & solved(robust->flags) & (naive_z[2] > 0);
  EXPECT_GT(cv::countNonZero(select), select.total() / 2);
  return {test::mean_angular_error_deg(normals_from_gradients(plain->p, plain->q), truth, select),
          test::mean_angular_error_deg(naive, truth, select),
          test::mean_angular_error_deg(normals_from_gradients(robust->p, robust->q), truth,
                                       select)};
}

void print(const char* scene, int lights, const Errors& e) {
  std::printf("%-28s %3d lights: plain LS %6.3f  naive rule %6.3f  --reject %6.3f deg\n", scene,
              lights, e.plain, e.naive, e.robust);
}

const test::Specular kGlossy{.strength = 0.5, .exponent = 40};

class GlossyScenes : public ::testing::TestWithParam<int> {};

// A glossy dome on a glossy plane, casting shadows on it.
TEST_P(GlossyScenes, DomeWithCastShadows) {
  const int count = GetParam();
  const cv::Size size(160, 160);
  const double radius = 50;
  const auto lights = test::dome_lights(count, 55);
  const auto surface = test::dome_surface(size, radius, 1);
  std::vector<cv::Mat> shadows;
  for (const auto& l : lights)
    shadows.push_back(test::dome_cast_shadow(size, radius, l));
  const Scan scan = test::render_scan(surface, lights, CV_16U, 0.005, 21, shadows, kGlossy);
  const Errors e = compare(scan, surface.normal);
  print("glossy dome, cast shadows", count, e);
  EXPECT_LT(e.robust, e.naive);
  EXPECT_LT(e.robust, e.plain);
}

// A glossy bumpy plane, shadowing itself.
TEST_P(GlossyScenes, BumpyPlaneWithCastShadows) {
  const int count = GetParam();
  const cv::Size size(160, 160);
  cv::Mat height;
  const auto surface = test::bumpy_surface(size, 6, 40, 1, &height);
  const auto lights = test::dome_lights(count, 55);
  std::vector<cv::Mat> shadows;
  for (const auto& l : lights)
    shadows.push_back(test::height_cast_shadow(height, l));
  const Scan scan = test::render_scan(surface, lights, CV_16U, 0.005, 22, shadows, kGlossy);
  const Errors e = compare(scan, surface.normal);
  print("glossy bumps, cast shadows", count, e);
  EXPECT_LT(e.robust, e.naive);
  EXPECT_LT(e.robust, e.plain);
}

INSTANTIATE_TEST_SUITE_P(Lights, GlossyScenes, ::testing::Values(8, 12, 64, 96),
                         [](const auto& p) { return std::to_string(p.param); });

}  // namespace
}  // namespace psrig::processing
