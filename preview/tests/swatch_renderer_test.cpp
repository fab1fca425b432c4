// The GLES swatch renderer against its CPU reference, pixel by pixel, on
// Mesa's llvmpipe; and the lighting behaving as the axes say it must.

#include "psrig/preview/swatch_renderer.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "psrig/preview/egl_context.h"
#include "psrig/preview/offscreen_target.h"
#include "psrig/preview/reference_render.h"
#include "psrig/preview/texture_levels.h"
#include "swatch_fixture.h"

namespace psrig::preview {
namespace {

// GL and the reference round the last bit of the sRGB encoding differently,
// so a pixel may be one code off; anything larger is a real disagreement.
constexpr int kMaxCodes = 2;
constexpr double kMeanCodes = 0.3;  // mean |difference| over all channels

struct Difference {
  int max = 0;
  double mean = 0;
  cv::Point worst;
};

Difference compare(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  Difference d;
  const cv::Mat channels = diff.reshape(1, diff.rows);
  double max = 0;
  cv::minMaxLoc(channels, nullptr, &max, nullptr, &d.worst);
  d.worst.x /= 3;
  d.max = static_cast<int>(max);
  d.mean = cv::mean(channels)[0];
  return d;
}

class SwatchRendererTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto context = EglContext::open_surfaceless();
    ASSERT_TRUE(context) << context.error().describe();
    context_ = std::move(*context);
  }

  // The GLES frame and the CPU reference of one flat view at texture level `level`.
  std::pair<cv::Mat, cv::Mat> render_both(const SwatchMaps& maps, const SceneView& view, int level,
                                          const RendererOptions& options = {}) {
    auto renderer = SwatchRenderer::create(maps, options);
    EXPECT_TRUE(renderer) << renderer.error().describe();
    if (!renderer) return {};
    const TextureLevels levels = build_texture_levels(maps, options.shading.default_gloss);
    auto reference = render_flat_reference(levels, level, maps.extent(), view, options.shading,
                                           options.background);
    EXPECT_TRUE(reference) << reference.error();
    if (!reference) return {};
    auto target = OffscreenTarget::create(reference->size(), 0, ColourStorage::srgb);
    EXPECT_TRUE(target) << target.error().describe();
    if (!target) return {};
    (*target)->bind();
    (*renderer)->draw(view, reference->size());
    return {(*target)->read(), *reference};
  }

  std::unique_ptr<EglContext> context_;
};

SceneView flat_view(LightKind kind, double tilt, double slant) {
  SceneView view;
  view.kind = ViewKind::flat;
  view.show_light = false;
  view.light.kind = kind;
  view.light.tilt_deg = tilt;
  view.light.slant_deg = slant;
  return view;
}

TEST_F(SwatchRendererTest, FlatDirectionalMatchesReference) {
  const SwatchMaps maps = testing::bump_swatch({96, 64});
  for (const double tilt : {0.0, 120.0, 240.0}) {
    const auto [gl, reference] = render_both(maps, flat_view(LightKind::directional, tilt, 45), 0);
    ASSERT_FALSE(gl.empty());
    const Difference d = compare(gl, reference);
    EXPECT_LE(d.max, kMaxCodes) << "tilt " << tilt << " worst at " << d.worst;
    EXPECT_LE(d.mean, kMeanCodes) << "tilt " << tilt;
  }
}

TEST_F(SwatchRendererTest, FlatPointLightMatchesReference) {
  const SwatchMaps maps = testing::bump_swatch({96, 64});
  SceneView view = flat_view(LightKind::point, 30, 40);
  view.light.distance = 0.6;  // close: the fall-off across the swatch is plain
  const auto [gl, reference] = render_both(maps, view, 0);
  ASSERT_FALSE(gl.empty());
  const Difference d = compare(gl, reference);
  EXPECT_LE(d.max, kMaxCodes) << "worst at " << d.worst;
  EXPECT_LE(d.mean, kMeanCodes);
}

TEST_F(SwatchRendererTest, GlossAndAlphaMapsMatchReference) {
  SwatchMaps maps = testing::bump_swatch({96, 64});
  maps.gloss.create(maps.size(), CV_32F);
  maps.alpha.create(maps.size(), CV_32F);
  for (int row = 0; row < maps.size().height; ++row)
    for (int col = 0; col < maps.size().width; ++col) {
      maps.gloss.at<float>(row, col) = static_cast<float>(col) / 95.0f;
      // Trimmed on the left, half transparent in a band, opaque elsewhere.
      maps.alpha.at<float>(row, col) = col < 16 ? 0.0f : (row >= 20 && row < 30 ? 0.5f : 1.0f);
    }
  RendererOptions options;
  options.shading.specular = 0.8f;
  options.shading.shininess = 60;
  options.background = {0.3f, 0.05f, 0.05f};
  const auto [gl, reference] =
      render_both(maps, flat_view(LightKind::directional, 200, 30), 0, options);
  ASSERT_FALSE(gl.empty());
  const Difference d = compare(gl, reference);
  EXPECT_LE(d.max, kMaxCodes) << "worst at " << d.worst;
  EXPECT_LE(d.mean, kMeanCodes);
  // The trimmed part shows the background, sRGB encoded.
  const cv::Vec3b background(srgb8(0.05f), srgb8(0.05f), srgb8(0.3f));
  EXPECT_EQ(gl.at<cv::Vec3b>(10, 5), background);
}

TEST_F(SwatchRendererTest, MinifiedSwatchMatchesReferenceMipmap) {
  // Bumps of 4 pixels seen at a quarter size: each pixel covers whole bumps,
  // and only the mipmap's averaged normals (with the Toksvig term) give the
  // reference's answer.
  const SwatchMaps maps = testing::bump_swatch({256, 128}, 4, 0.6f);
  RendererOptions options;
  options.shading.specular = 0.6f;
  const auto [gl, reference] =
      render_both(maps, flat_view(LightKind::directional, 0, 60), 2, options);
  ASSERT_FALSE(gl.empty());
  EXPECT_EQ(gl.size(), cv::Size(64, 32));
  const Difference d = compare(gl, reference);
  EXPECT_LE(d.max, kMaxCodes) << "worst at " << d.worst;
  EXPECT_LE(d.mean, kMeanCodes);
}

TEST_F(SwatchRendererTest, BumpFacingPlusXBrightensUnderTiltZero) {
  const SwatchMaps maps = testing::bump_swatch({64, 64});
  auto renderer = SwatchRenderer::create(maps, {});
  ASSERT_TRUE(renderer) << renderer.error().describe();
  auto target = OffscreenTarget::create(maps.size(), 0, ColourStorage::srgb);
  ASSERT_TRUE(target);
  const auto brightness = [&](double tilt) {
    (*target)->bind();
    (*renderer)->draw(flat_view(LightKind::directional, tilt, 60), maps.size());
    cv::Mat grey;
    cv::cvtColor((*target)->read(), grey, cv::COLOR_BGR2GRAY);
    return grey;
  };
  const cv::Mat from_plus_x = brightness(0);
  const cv::Mat from_minus_x = brightness(180);
  // Pixels by the direction they face (from the known normals).
  double facing_plus = 0, facing_minus = 0;
  int count_plus = 0, count_minus = 0;
  for (int row = 0; row < 64; ++row)
    for (int col = 0; col < 64; ++col) {
      const float nx = maps.normal.at<cv::Vec3f>(row, col)[0];
      const double gain =
          double(from_plus_x.at<std::uint8_t>(row, col)) - from_minus_x.at<std::uint8_t>(row, col);
      if (nx > 0.3f) facing_plus += gain, ++count_plus;
      if (nx < -0.3f) facing_minus += gain, ++count_minus;
    }
  ASSERT_GT(count_plus, 100);
  ASSERT_GT(count_minus, 100);
  EXPECT_GT(facing_plus / count_plus, 20) << "facets facing +x are brighter lit from tilt 0";
  EXPECT_LT(facing_minus / count_minus, -20) << "facets facing -x are darker lit from tilt 0";
}

TEST_F(SwatchRendererTest, OutputIsSrgbEncodedEitherWay) {
  // White, flat, lit from straight above with half strength: linear 0.5 is
  // sRGB code 188, whether the framebuffer or the shader encodes.
  SwatchMaps maps = testing::bump_swatch({32, 32});
  maps.albedo.setTo(cv::Scalar::all(1.0));
  maps.normal.setTo(cv::Scalar(0, 0, 1));
  for (const bool shader_encodes : {false, true}) {
    RendererOptions options;
    options.shading = {.ambient = 0, .diffuse = 0.5f, .specular = 0};
    options.encode_srgb = shader_encodes;
    auto renderer = SwatchRenderer::create(maps, options);
    ASSERT_TRUE(renderer);
    auto target = OffscreenTarget::create(
        maps.size(), 0, shader_encodes ? ColourStorage::linear : ColourStorage::srgb);
    ASSERT_TRUE(target);
    (*target)->bind();
    (*renderer)->draw(flat_view(LightKind::directional, 0, 0), maps.size());
    const cv::Mat frame = (*target)->read();
    EXPECT_NEAR(frame.at<cv::Vec3b>(16, 16)[1], 188, 1) << "shader encodes: " << shader_encodes;
  }
}

// Mean absolute change between two frames a small camera turn apart.
double shimmer(SwatchRenderer& renderer, OffscreenTarget& target) {
  SceneView view;
  view.kind = ViewKind::patch;
  view.show_light = false;
  view.zoom = 0.35;  // far away: many knit loops to a pixel
  view.light.slant_deg = 50;
  cv::Mat frames[2];
  for (int i = 0; i < 2; ++i) {
    view.camera_yaw_deg = 10 + 0.15 * i;
    target.bind();
    renderer.draw(view, target.size());
    cv::cvtColor(target.read(), frames[i], cv::COLOR_BGR2GRAY);
  }
  cv::Mat diff;
  cv::absdiff(frames[0], frames[1], diff);
  return cv::mean(diff)[0];
}

TEST_F(SwatchRendererTest, MipmapsAndMultisamplingStopShimmerAtADistance) {
  const SwatchMaps maps = testing::bump_swatch({256, 256}, 3, 0.5f);
  RendererOptions options;
  options.shading.specular = 0.8f;
  RendererOptions base_level_only = options;
  base_level_only.mipmaps = false;
  auto smooth = SwatchRenderer::create(maps, options);
  auto raw = SwatchRenderer::create(maps, base_level_only);
  ASSERT_TRUE(smooth && raw);
  auto multisampled = OffscreenTarget::create({160, 120}, 4, ColourStorage::srgb);
  auto single = OffscreenTarget::create({160, 120}, 0, ColourStorage::srgb);
  ASSERT_TRUE(multisampled && single);
  const double with = shimmer(**smooth, **multisampled);
  const double without = shimmer(**raw, **single);
  EXPECT_LT(with * 3, without) << "shimmer " << with << " against " << without;
}

TEST_F(SwatchRendererTest, LightSphereDrawnWhereTheLightIs) {
  const SwatchMaps maps = testing::bump_swatch({64, 64});
  RendererOptions options;
  options.shading.light_colour = {1.0f, 0.9f, 0.2f};  // yellow: unlike the swatch
  auto renderer = SwatchRenderer::create(maps, options);
  ASSERT_TRUE(renderer);
  const cv::Size size(200, 150);
  auto target = OffscreenTarget::create(size, 0, ColourStorage::srgb);
  ASSERT_TRUE(target);
  SceneView view;
  view.kind = ViewKind::patch;
  view.light = {LightKind::point, 45, 50, 0.7};
  (*target)->bind();
  (*renderer)->draw(view, size);
  const cv::Mat frame = (*target)->read();
  const FrameSetup setup = frame_setup(maps.extent(), view, size);
  const Eigen::Vector4f clip = setup.projection * setup.view * setup.marker_centre.homogeneous();
  const int col = static_cast<int>((clip.x() / clip.w() + 1) / 2 * size.width);
  const int row = static_cast<int>((1 - clip.y() / clip.w()) / 2 * size.height);
  ASSERT_TRUE(cv::Rect({}, size).contains({col, row})) << col << "," << row;
  const cv::Vec3b centre = frame.at<cv::Vec3b>(row, col);
  EXPECT_GT(centre[2], 200) << "red";
  EXPECT_GT(centre[1], 190) << "green";
  EXPECT_LT(centre[0], 150) << "blue";
}

TEST_F(SwatchRendererTest, DrapedPatchFillsTheFrame) {
  const SwatchMaps maps = testing::bump_swatch({64, 64});
  auto renderer = SwatchRenderer::create(maps, {});
  ASSERT_TRUE(renderer);
  auto target = OffscreenTarget::create({160, 120}, 4, ColourStorage::srgb);
  ASSERT_TRUE(target);
  SceneView view;
  view.kind = ViewKind::patch;
  view.camera_pitch_deg = 25;
  view.model_yaw_deg = 20;
  (*target)->bind();
  (*renderer)->draw(view, {160, 120});
  const cv::Mat frame = (*target)->read();
  const RendererOptions defaults;
  const cv::Scalar background(srgb8(defaults.background[2]), srgb8(defaults.background[1]),
                              srgb8(defaults.background[0]));
  cv::Mat off_background;
  cv::absdiff(frame, background, off_background);
  cv::cvtColor(off_background, off_background, cv::COLOR_BGR2GRAY);
  const double covered = cv::countNonZero(off_background > 3) / double(frame.total());
  EXPECT_GT(covered, 0.3);
  EXPECT_LT(covered, 0.95);
}

}  // namespace
}  // namespace psrig::preview
