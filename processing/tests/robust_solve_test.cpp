// Outlier rejection (--reject) on glossy surfaces, against plain least
// squares and the naive rule it must beat: per pixel, drop the darkest
// quarter and the brightest sixth of the values (n / 4 and n / 6, rounded
// down: 2 and 1 of 8, 3 and 2 of 12, 16 and 10 of 64, 24 and 16 of 96), then
// least squares. Every figure in this file is SYNTHETIC: Lambertian plus a
// Blinn-Phong lobe, cast shadows and noise, with known normals (the real
// captures are in real_data_test.cpp). Dome lights (Fibonacci spiral within
// 55 degrees of the axis), 16-bit frames, noise 0.005 of full scale,
// Blinn-Phong strength 0.5 and exponent 40 on albedo 0.35-0.65.
// Measured mean angular error, degrees, plain LS / naive rule / --reject:
//   dome on a plane, cast shadows:  8 lights 10.24 / 7.12 / 4.19
//                                  12 lights  8.15 / 4.52 / 3.54
//                                  64 lights  7.80 / 3.17 / 2.29
//                                  96 lights  7.75 / 3.07 / 2.21
//   bumpy plane, cast shadows:      8 lights  6.60 / 4.61 / 3.23
//                                  12 lights  6.59 / 3.59 / 2.49
//                                  64 lights  6.59 / 3.39 / 2.15
//                                  96 lights  6.61 / 3.14 / 2.12

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

cv::Mat solved(const cv::Mat& flags) {
  cv::Mat unsolved;
  cv::bitwise_and(flags, cv::Scalar(kOutsideMask | kLowSignal | kNoSolution), unsolved);
  return unsolved == 0;
}

struct Errors {
  double plain = 0, naive = 0, robust = 0;
};

// Mean angular errors (degrees) of the three over the pixels all three solve.
Errors compare(const formats::Scan& scan, const cv::Mat& truth) {
  auto plain = solve(scan);
  auto robust = solve(scan, {.reject_outliers = true});
  EXPECT_TRUE(plain && robust);
  if (!plain || !robust) return {};
  const cv::Mat naive = test::naive_rule_normals(scan);
  std::vector<cv::Mat> naive_z;
  cv::split(naive, naive_z);
  const cv::Mat select = solved(plain->flags) & solved(robust->flags) & (naive_z[2] > 0);
  EXPECT_GT(cv::countNonZero(select), select.total() / 2);
  return {
      test::mean_angular_error_deg(normals_from_gradients(plain->p, plain->q), truth, select),
      test::mean_angular_error_deg(naive, truth, select),
      test::mean_angular_error_deg(normals_from_gradients(robust->p, robust->q), truth, select)};
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
  const formats::Scan scan =
      test::render_scan(surface, lights, CV_16U, 0.005, 21, shadows, kGlossy);
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
  const formats::Scan scan =
      test::render_scan(surface, lights, CV_16U, 0.005, 22, shadows, kGlossy);
  const Errors e = compare(scan, surface.normal);
  print("glossy bumps, cast shadows", count, e);
  EXPECT_LT(e.robust, e.naive);
  EXPECT_LT(e.robust, e.plain);
}

INSTANTIATE_TEST_SUITE_P(Lights, GlossyScenes, ::testing::Values(8, 12, 64, 96),
                         [](const auto& p) { return std::to_string(p.param); });

}  // namespace
}  // namespace psrig::processing
