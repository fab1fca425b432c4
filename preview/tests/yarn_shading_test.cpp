// The yarn shading's CPU maths (the GLSL twins are held to it in
// preview/tests/yarn_renderer_test.cpp): the elliptical section's silhouette and
// normals against brute force, the shadows, multiple scattering, the
// environment's interpolation, the lobes where they should be.

#include "psrig/preview/yarn_shading.h"

#include <cmath>
#include <numbers>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace psrig::preview {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;

// The ellipse of a yarn along x whose cloth normal is +z: radius across
// (y), flatness * radius along z, sampled round.
Eigen::Vector3f ellipse_point(float angle, float radius, float flatness) {
  return {0, radius * std::cos(angle), flatness * radius * std::sin(angle)};
}
Eigen::Vector3f ellipse_normal(float angle, float radius, float flatness) {
  return Eigen::Vector3f(0, std::cos(angle) / radius, std::sin(angle) / (flatness * radius))
      .normalized();
}

TEST(YarnShading, RoundYarnFacesTheEyeInTheMiddleAndTheSidesAtTheEdges) {
  const Eigen::Vector3f tangent = Eigen::Vector3f::UnitX();
  const Eigen::Vector3f to_eye(0.3f, 0, 5);  // along the yarn a little: ignored
  const StripFrame frame = strip_frame(tangent, Eigen::Vector3f::UnitZ(), to_eye, 0.7f, 1);
  EXPECT_NEAR(frame.half_width_mm, 0.7f, 1e-6f);
  EXPECT_TRUE(strip_normal(frame, 0).isApprox(Eigen::Vector3f::UnitZ()));
  EXPECT_TRUE(strip_normal(frame, 1).isApprox(frame.side));
  EXPECT_TRUE(strip_normal(frame, -1).isApprox(-frame.side));
  EXPECT_TRUE(frame.side.isApprox(-Eigen::Vector3f::UnitY()));
  const Eigen::Vector3f half = strip_normal(frame, 0.5f);
  EXPECT_NEAR(half.norm(), 1, 1e-6f);
  EXPECT_NEAR(half.dot(tangent), 0, 1e-6f);
  EXPECT_NEAR(frame.turn, 0, 1e-6f) << "the slice is baked for this view";
}

TEST(YarnShading, FlatYarnLooksAsWideAsItsEllipseFromAnyAngle) {
  const float radius = 0.8f, flatness = 0.4f;
  for (const float view_deg : {90.0f, 60.0f, 30.0f, 0.0f, -45.0f}) {
    const float view = view_deg * kPi / 180;
    // Looking at the yarn from `view` above the cloth's plane, across it.
    const Eigen::Vector3f to_eye(0, std::cos(view), std::sin(view));
    const StripFrame frame = strip_frame(Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitZ(),
                                         to_eye, radius, flatness);
    float widest = 0;
    for (int i = 0; i < 3600; ++i) {
      const Eigen::Vector3f p = ellipse_point(2 * kPi * i / 3600.0f, radius, flatness);
      widest = std::max(widest, std::abs(p.dot(frame.side)));
    }
    EXPECT_NEAR(frame.half_width_mm, widest, 1e-3f) << view_deg << " degrees";
    if (view_deg == 90) {
      EXPECT_NEAR(frame.half_width_mm, radius, 1e-5f) << "head on";
    }
    if (view_deg == 0) {
      EXPECT_NEAR(frame.half_width_mm, flatness * radius, 1e-5f) << "edge on";
    }
  }
}

TEST(YarnShading, StripNormalIsTheEllipsesWhereTheEyeMeetsIt) {
  const float radius = 1.0f, flatness = 0.5f;
  const Eigen::Vector3f to_eye(0, 0.6f, 0.8f);  // 53 degrees above the cloth
  const StripFrame frame =
      strip_frame(Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitZ(), to_eye, radius, flatness);
  for (const float across : {-0.9f, -0.5f, 0.0f, 0.3f, 0.8f}) {
    // Brute force: the point of the ellipse nearest the eye among those
    // at this strip coordinate.
    float best_angle = 0, best_depth = -1e9f;
    for (int i = 0; i < 36000; ++i) {
      const float angle = 2 * kPi * i / 36000.0f;
      const Eigen::Vector3f p = ellipse_point(angle, radius, flatness);
      if (std::abs(p.dot(frame.side) - across * frame.half_width_mm) > 2e-3f) continue;
      if (p.dot(frame.facing) > best_depth) best_depth = p.dot(frame.facing), best_angle = angle;
    }
    const Eigen::Vector3f expected = ellipse_normal(best_angle, radius, flatness);
    EXPECT_GT(strip_normal(frame, across).dot(expected), 0.9995f) << "across " << across;
  }
}

TEST(YarnShading, ShadowMapIsReadAtTheEllipsesPointNearestTheLight) {
  const float radius = 0.9f, flatness = 0.5f;
  const Eigen::Vector3f to_light(0.2f, -0.5f, 0.7f);
  const Eigen::Vector3f surface = toward_light_surface(
      Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitZ(), to_light, radius, flatness);
  float best = -1e9f;
  for (int i = 0; i < 36000; ++i)
    best = std::max(best, ellipse_point(2 * kPi * i / 36000.0f, radius, flatness)
                              .dot(to_light.normalized()));
  EXPECT_NEAR(surface.dot(to_light.normalized()), best, 1e-4f);
  EXPECT_NEAR(surface.x(), 0, 1e-6f) << "in the cross-section";
}

TEST(YarnShading, FibresTwistByTheHelixAngle) {
  cloth::YarnStyle style;
  style.radius_mm = 0.5f;
  style.twist_pitch_mm = 2;
  const float angle = ply_helix_angle(style);
  EXPECT_NEAR(std::tan(angle), kPi * 0.5f / 2, 1e-5f);
  EXPECT_NEAR(plain_surface(style).tilt_sin, std::sin(angle), 1e-6f);
  style.twist_pitch_mm = 0;
  EXPECT_EQ(ply_helix_angle(style), 0) << "untwisted";
}

TEST(YarnShading, CrossingLightDarkensBetweenTheLayersOnly) {
  const FibreShading shading;
  EXPECT_FLOAT_EQ(crossing_light(1, shading), 1);
  EXPECT_FLOAT_EQ(crossing_light(-1, shading), 1);
  EXPECT_FLOAT_EQ(crossing_light(-1.4f, shading), 1);
  EXPECT_FLOAT_EQ(crossing_light(0, shading), 1 - shading.crossing_occlusion);
}

TEST(YarnShading, StatisticalShadowsDeepenUnderTheClothAndAtGrazingLight) {
  const FibreShading shading;
  const Eigen::Vector3f up = Eigen::Vector3f::UnitZ();
  const auto light = [](float slant_deg) {
    const float s = slant_deg * kPi / 180;
    return Eigen::Vector3f(std::sin(s), 0, std::cos(s));
  };
  EXPECT_FLOAT_EQ(statistical_shadow(1, up, light(60), shading), 1) << "on top: nothing above";
  EXPECT_FLOAT_EQ(statistical_shadow(-1, up, light(0), shading), 1) << "light from straight above";
  const float under_30 = statistical_shadow(-1, up, light(30), shading);
  const float under_70 = statistical_shadow(-1, up, light(70), shading);
  const float middle_70 = statistical_shadow(0, up, light(70), shading);
  EXPECT_LT(under_70, under_30);
  EXPECT_LT(under_70, middle_70);
  EXPECT_LT(middle_70, 1);
  // Lit from behind, the back's top is the front's bottom.
  EXPECT_FLOAT_EQ(statistical_shadow(-1, up, -light(60), shading), 1);
  EXPECT_NEAR(statistical_shadow(1, up, -light(60), shading), statistical_shadow(-1, up, light(60), shading),
              1e-6f);
}

TEST(YarnShading, MultipleScatteringBrightensAndLightensLightYarnMore) {
  const FibreShading shading;
  const Eigen::Vector3f white(0.85f, 0.85f, 0.85f), black(0.03f, 0.03f, 0.03f);
  const Eigen::Vector3f white_gain = local_scattering_gain(white, shading);
  const Eigen::Vector3f black_gain = local_scattering_gain(black, shading);
  EXPECT_GT(white_gain.x(), 1.3f);
  EXPECT_LT(black_gain.x(), 1.02f);
  EXPECT_EQ(local_scattering_gain(Eigen::Vector3f::Zero(), shading), Eigen::Vector3f::Ones());
  // A fully shadowed point still gets what light yarn passes on, tinted.
  const Eigen::Vector3f red(0.8f, 0.1f, 0.1f);
  const Eigen::Vector3f through = transmitted_shadow(0, red, shading);
  EXPECT_NEAR(through.x(), shading.global_scattering * 0.8f, 1e-6f);
  EXPECT_GT(through.x(), 5 * through.y());
  EXPECT_EQ(transmitted_shadow(1, red, shading), Eigen::Vector3f::Ones());
}

TEST(YarnShading, EnvironmentAcrossPassesThroughItsThreeValues) {
  VertexShading vertex;
  vertex.environment = {Eigen::Vector3f(0.1f, 0.2f, 0.3f), Eigen::Vector3f(0.5f, 0.4f, 0.2f),
                        Eigen::Vector3f(0.2f, 0.1f, 0.0f)};
  EXPECT_TRUE(environment_across(vertex, -1).isApprox(vertex.environment[0]));
  EXPECT_TRUE(environment_across(vertex, 0).isApprox(vertex.environment[1]));
  EXPECT_TRUE(environment_across(vertex, 1).isApprox(vertex.environment[2]));
  EXPECT_TRUE(environment_across(vertex, 3).isApprox(vertex.environment[2])) << "clamped";
}

TEST(YarnShading, UniformEnvironmentIsTheOldAmbient) {
  // A uniform sky of radiance 1 on a yarn with no multiple scattering and no
  // sheen: the albedo, from any side.
  FibreShading shading;
  shading.local_scattering = 0;
  shading.environment_sheen = 0;
  const EnvironmentLight sky = EnvironmentLight::uniform(Eigen::Vector3f::Ones());
  const Eigen::Vector3f albedo(0.6f, 0.3f, 0.2f);
  for (const Eigen::Vector3f& normal : {Eigen::Vector3f(0, 0, 1), Eigen::Vector3f(0, -1, 0)}) {
    const Eigen::Vector3f shaded = environment_shading(sky, normal, Eigen::Vector3f::UnitX(),
                                                       Eigen::Vector3f::UnitZ(), albedo, shading);
    EXPECT_TRUE(shaded.isApprox(albedo, 1e-4f)) << shaded.transpose();
  }
}

TEST(YarnShading, ReflectionIsWhiteTransmissionTintedAndForward) {
  FibreShading shading;
  shading.diffuse = 0;
  const Eigen::Vector3f red(0.8f, 0.05f, 0.05f);
  const StripFrame frame =
      strip_frame(Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitZ(), Eigen::Vector3f::UnitZ(), 1, 1);
  VertexShading vertex;
  vertex.environment.fill(Eigen::Vector3f::Zero());
  vertex.direct = Eigen::Vector3f::Ones();
  vertex.albedo = red;
  const FibreSurface straight{0, 0, 1};
  const Eigen::Vector3f along = ply_across_direction(frame, 0);
  const auto shade = [&](const FibreShading& s, const Eigen::Vector3f& to_light) {
    return shade_fragment(frame, 0, straight, along, vertex, to_light, Eigen::Vector3f::UnitZ(), s);
  };
  FibreShading reflection_only = shading;
  reflection_only.tt_weight = 0;
  // The R peak: the half angle's sine at the shift.
  const float s = 2 * shading.r_shift;
  const Eigen::Vector3f white = shade(reflection_only, Eigen::Vector3f(s, 0, std::sqrt(1 - s * s)));
  EXPECT_NEAR(white.x(), white.z(), 1e-6f) << "R is the light's colour";
  EXPECT_GT(white.x(), 0.5f * shading.r_weight);
  FibreShading transmission_only = shading;
  transmission_only.r_weight = 0;
  // From behind the yarn, through it toward the eye: TT, in the yarn's colour.
  const Eigen::Vector3f behind(2 * shading.tt_shift, 0, -1);
  const Eigen::Vector3f through = shade(transmission_only, behind);
  EXPECT_GT(through.x(), 10 * through.z());
  EXPECT_GT(through.x(), 0.5f * shading.tt_weight * red.x());
  const Eigen::Vector3f in_front = shade(transmission_only, Eigen::Vector3f(0, 0, 1));
  EXPECT_LT(in_front.x(), 0.01f * through.x()) << "TT scatters forward only";
}

TEST(YarnShading, SliceTiltsTheNormalAcrossThePlies) {
  const FibreShading shading;
  const StripFrame frame =
      strip_frame(Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitZ(), Eigen::Vector3f::UnitZ(), 1, 1);
  VertexShading vertex;
  vertex.environment.fill(Eigen::Vector3f::Zero());
  vertex.direct = Eigen::Vector3f::Ones();
  vertex.albedo = Eigen::Vector3f::Constant(0.5f);
  const Eigen::Vector3f across = ply_across_direction(frame, 0);
  // Light from the strip's +side: a ply's flank turned that way is brighter.
  const Eigen::Vector3f to_light = frame.side + Eigen::Vector3f::UnitZ() * 0.3f;
  const auto at = [&](float ply) {
    return shade_fragment(frame, 0, {ply, 0, 1}, across, vertex, to_light,
                          Eigen::Vector3f::UnitZ(), shading)
        .x();
  };
  EXPECT_GT(at(0.8f), at(0) + 0.05f);
  EXPECT_LT(at(-0.8f), at(0) - 0.05f);
  // The slice's light scales the whole point.
  EXPECT_NEAR(shade_fragment(frame, 0, {0, 0, 0.5f}, across, vertex, to_light,
                             Eigen::Vector3f::UnitZ(), shading)
                  .x(),
              0.5f * at(0), 1e-6f);
}

}  // namespace
}  // namespace psrig::preview

namespace psrig::preview {
namespace {

TEST(YarnShading, PrefilteredCoverageKeepsTheYarnsShareAndSoftensItsEdges) {
  for (const float half : {0.2f, 0.5f, 2.0f})
    for (const float filter : {0.3f, 1.0f, 1.5f}) {
      double integral = 0;
      constexpr double kStep = 0.001;
      for (double d = -6; d <= 6; d += kStep)
        integral += prefiltered_coverage(static_cast<float>(d), half, filter) * kStep;
      EXPECT_NEAR(integral, 2 * half, 2e-3) << "half " << half << ", filter " << filter;
      EXPECT_LE(prefiltered_coverage(0, half, filter), 1.0f);
      EXPECT_FLOAT_EQ(prefiltered_coverage(half + filter, half, filter), 0.0f);
    }
  // No filter: the yarn's own edges.
  EXPECT_FLOAT_EQ(prefiltered_coverage(0.49f, 0.5f, 0), 1.0f);
  EXPECT_FLOAT_EQ(prefiltered_coverage(0.51f, 0.5f, 0), 0.0f);
  // A thin yarn's share spread thin over its filter.
  EXPECT_NEAR(prefiltered_coverage(0, 0.1f, 1), 0.2f * (1 - 0.05f), 1e-3f);
}

}  // namespace
}  // namespace psrig::preview
