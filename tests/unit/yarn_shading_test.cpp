// The yarn shading's CPU maths (the GLSL twin is held to it in
// tests/gl/yarn_renderer_test.cpp): the tube's normal, the detail's mean,
// the lobes where they should be.

#include "psrig/preview/yarn_shading.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

namespace psrig::preview {
namespace {

TEST(YarnShading, TubeNormalFacesTheEyeInTheMiddleAndTheSidesAtTheEdges) {
  const Eigen::Vector3f tangent = Eigen::Vector3f::UnitX();
  const Eigen::Vector3f to_eye(0.3f, 0, 5);  // along the yarn a little: ignored
  EXPECT_TRUE(tube_normal(tangent, to_eye, 0).isApprox(Eigen::Vector3f::UnitZ()));
  EXPECT_TRUE(tube_normal(tangent, to_eye, 1).isApprox(-Eigen::Vector3f::UnitY()));
  EXPECT_TRUE(tube_normal(tangent, to_eye, -1).isApprox(Eigen::Vector3f::UnitY()));
  const Eigen::Vector3f half = tube_normal(tangent, to_eye, 0.5f);
  EXPECT_NEAR(half.norm(), 1, 1e-6f);
  EXPECT_NEAR(half.dot(tangent), 0, 1e-6f);
}

TEST(YarnShading, FibresTwistByTheHelixAngle) {
  cloth::YarnStyle style;
  style.radius_mm = 0.5f;
  style.twist_pitch_mm = 2;
  const float angle = ply_helix_angle(style);
  EXPECT_NEAR(std::tan(angle), std::numbers::pi_v<float> * 0.5f / 2, 1e-5f);
  const Eigen::Vector3f fibre =
      fibre_tangent(Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitZ(), angle);
  EXPECT_NEAR(fibre.dot(Eigen::Vector3f::UnitX()), std::cos(angle), 1e-6f);
  EXPECT_NEAR(fibre.norm(), 1, 1e-6f);
}

TEST(YarnShading, CrossingLightDarkensBetweenTheLayersOnly) {
  const FibreShading shading;
  EXPECT_FLOAT_EQ(crossing_light(1, shading), 1);
  EXPECT_FLOAT_EQ(crossing_light(-1, shading), 1);
  EXPECT_FLOAT_EQ(crossing_light(-1.4f, shading), 1);
  EXPECT_FLOAT_EQ(crossing_light(0, shading), 1 - shading.crossing_occlusion);
}

TEST(YarnShading, DetailAveragesToItsMeanAndFadesToItBelowAPixel) {
  const cloth::YarnStyle style;
  const FibreShading shading;
  double sum = 0;
  constexpr int kSamples = 20000;
  for (int i = 0; i < kSamples; ++i) {
    const float around = 2 * std::numbers::pi_v<float> * (static_cast<float>(i) + 0.5f) / kSamples;
    sum += fibre_detail(around, 0.7f, style, shading);
  }
  // The striation's hashed values average to zero only roughly: 2%.
  EXPECT_NEAR(sum / kSamples, mean_fibre_detail(shading), 0.02);
  // Grooves dark, ply middles bright, with the fibres resolved...
  EXPECT_LT(fibre_detail(std::numbers::pi_v<float> / 2, 0, style, shading), 0.6f);
  EXPECT_GT(fibre_detail(0, 0, style, shading), 0.85f);
  // ... and both the mean where a pixel holds several plies.
  EXPECT_FLOAT_EQ(fibre_detail(0.3f, 1.1f, style, shading, 100), mean_fibre_detail(shading));
  // Seamless round the yarn.
  EXPECT_NEAR(fibre_detail(-std::numbers::pi_v<float> + 1e-4f, 0, style, shading),
              fibre_detail(std::numbers::pi_v<float> - 1e-4f, 0, style, shading), 0.01f);
}

TEST(YarnShading, PrimaryLobeWhiteSecondaryTinted) {
  FibreShading shading;
  shading.ambient = 0;
  shading.diffuse = 0;
  const Eigen::Vector3f red(0.8f, 0.05f, 0.05f);
  const FibrePoint point{Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitZ(), red, 1};
  // The highlight of a fibre along x: half vector near the normal, shifted.
  const auto at = [&](float tilt) {
    const Eigen::Vector3f to_light(std::sin(tilt), 0, std::cos(tilt));
    return shade_fibres(point, to_light, Eigen::Vector3f::UnitZ(), 1, 1, shading);
  };
  FibreShading primary_only = shading;
  primary_only.secondary_specular = 0;
  const Eigen::Vector3f white = shade_fibres(point, {0.2f, 0, 1}, {0, 0, 1}, 1, 1, primary_only);
  EXPECT_NEAR(white.x(), white.z(), 1e-6f) << "R is the light's colour";
  FibreShading secondary_only = shading;
  secondary_only.primary_specular = 0;
  const Eigen::Vector3f tinted =
      shade_fibres(point, {-0.3f, 0, 1}, {0, 0, 1}, 1, 1, secondary_only);
  EXPECT_GT(tinted.x(), 10 * tinted.z()) << "TRT takes the yarn's colour";
  EXPECT_GT(at(0.3f).norm(), 0);
  // No light reaching (shadow 0): nothing but ambient, here none.
  EXPECT_EQ(shade_fibres(point, {0, 0, 1}, {0, 0, 1}, 1, 0, shading), Eigen::Vector3f::Zero());
}

}  // namespace
}  // namespace psrig::preview
