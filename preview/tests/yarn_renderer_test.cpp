// The GLES yarn renderer on Mesa's llvmpipe: a straight yarn held to the
// CPU shading pixel by pixel (plain, and with the slice's fibre detail), a
// flattened yarn's width, shadows where yarns cross, the far view against a
// supersampled reference (no aliasing), the levels of detail blending
// without a pop, and updates.

#include "psrig/preview/yarn_renderer.h"

#include <GLES3/gl3.h>

#include <algorithm>

#include <Eigen/LU>
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "psrig/cloth/knit_fabric.h"
#include "psrig/preview/egl_context.h"
#include "psrig/preview/offscreen_target.h"
#include "psrig/preview/shading.h"
#include "cloth_pixels.h"
#include "psrig/preview/texture_levels.h"
#include "test_support.h"
#include "yarn_fixture.h"

namespace psrig::preview {
namespace {

const cv::Size kFrame(320, 240);

class YarnRendererTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto context = EglContext::open_surfaceless();
    ASSERT_TRUE(context) << context.error().describe();
    context_ = std::move(*context);
  }

  std::unique_ptr<YarnRenderer> make_renderer(const YarnRendererOptions& options = {}) {
    auto renderer = YarnRenderer::create(options);
    EXPECT_TRUE(renderer) << renderer.error().describe();
    return renderer ? std::move(*renderer) : nullptr;
  }

  std::unique_ptr<OffscreenTarget> make_target(int samples = 4, cv::Size size = kFrame) {
    auto target = OffscreenTarget::create(size, samples, ColourStorage::srgb);
    EXPECT_TRUE(target) << target.error().describe();
    return target ? std::move(*target) : nullptr;
  }

  static cv::Mat draw(YarnRenderer& renderer, OffscreenTarget& target, const KnitView& view) {
    target.bind();
    renderer.render(view, target.size());
    EXPECT_EQ(glGetError(), static_cast<GLenum>(GL_NO_ERROR));
    return target.read();
  }

  std::unique_ptr<EglContext> context_;
};

KnitView plain_view(double distance_mm) {
  KnitView view;
  view.distance_mm = distance_mm;
  view.light.tilt_deg = 30;
  view.light.slant_deg = 40;
  view.shadows = false;
  view.fibre_detail = false;
  return view;
}

cv::Vec3b background_code(const KnitView& view) {
  return {srgb8(view.background[2]), srgb8(view.background[1]), srgb8(view.background[0])};
}

// Where a pixel centre's ray meets the plane z = `z`.
Eigen::Vector3f unproject(const KnitFrame& frame, cv::Size size, float col, float row, float z) {
  const Eigen::Matrix4f inverse = (frame.projection * frame.view).inverse();
  const float x = col / static_cast<float>(size.width) * 2 - 1;
  const float y = 1 - row / static_cast<float>(size.height) * 2;
  const Eigen::Vector4f near = inverse * Eigen::Vector4f(x, y, -1, 1);
  const Eigen::Vector4f far = inverse * Eigen::Vector4f(x, y, 1, 1);
  const Eigen::Vector3f a = near.head<3>() / near.w(), b = far.head<3>() / far.w();
  return a + (b - a) * ((z - a.z()) / (b.z() - a.z()));
}

double mean_grey(const cv::Mat& frame, const cv::Rect& box) {
  cv::Mat grey;
  cv::cvtColor(frame(box), grey, cv::COLOR_BGR2GRAY);
  return cv::mean(grey)[0];
}

// What the renderer packs: colours as sRGB bytes, lifts as signed bytes.
Eigen::Vector3f packed_colour(const Eigen::Vector3f& linear) {
  Eigen::Vector3f out;
  for (int c = 0; c < 3; ++c)
    out[c] = srgb_decode(static_cast<float>(srgb8(linear[c])) / 255.0f);
  return out;
}
float packed_lift(float lift) {
  return std::round(std::clamp(lift, -1.0f, 1.0f) * 127.0f) / 127.0f;
}

// A straight yarn head on, along x through the origin, every covered pixel
// held to the CPU twin: `surface_at(across, arc)` gives the fibre surface.
struct GoldenResult {
  int compared = 0, worst = 0;
  double mean = 0;
  cv::Point worst_at;
};
template <class Surface>
GoldenResult compare_straight_yarn(const cv::Mat& frame, const YarnRenderer& renderer,
                                   const KnitView& view, const Eigen::Vector3f& colour, float lift,
                                   float x_from, float max_across, Surface surface_at) {
  const KnitFrame setup = knit_frame(renderer.bounds(), view, kFrame);
  const YarnRendererOptions& options = renderer.options();
  const cloth::YarnStyle& style = renderer.style();
  const Eigen::Vector3f tangent = Eigen::Vector3f::UnitX();
  const Eigen::Vector3f albedo = packed_colour(colour);
  GoldenResult result;
  double total = 0;
  for (int row = 0; row < kFrame.height; ++row)
    for (int col = 0; col < kFrame.width; ++col) {
      const Eigen::Vector3f strip = unproject(setup, kFrame, col + 0.5f, row + 0.5f, 0);
      const Eigen::Vector3f centre(strip.x(), 0, 0);
      const StripFrame frame_here = strip_frame(tangent, Eigen::Vector3f::UnitZ(),
                                                setup.eye - centre, style.radius_mm, style.flatness);
      const float across = frame_here.side.dot(strip - centre) / frame_here.half_width_mm;
      if (std::abs(across) > max_across || strip.x() < x_from + 2 || strip.x() > -x_from - 2)
        continue;
      const VertexShading vertex =
          vertex_shading(frame_here, albedo, packed_lift(lift), setup.eye - centre, 1, 1,
                         options.environment, options.shading);
      const Eigen::Vector3f linear_colour = shade_fragment(
          frame_here, across, surface_at(across, strip.x() - x_from, frame_here), 
          ply_across_direction(frame_here, renderer.slice().ply_slant_sin), vertex,
          setup.light.head<3>(), setup.eye - strip, options.shading);
      const cv::Vec3b expected(srgb8(linear_colour[2]), srgb8(linear_colour[1]),
                               srgb8(linear_colour[0]));
      const cv::Vec3b got = frame.at<cv::Vec3b>(row, col);
      for (int c = 0; c < 3; ++c) {
        const int difference = std::abs(int(got[c]) - int(expected[c]));
        total += difference;
        if (difference > result.worst) result.worst = difference, result.worst_at = {col, row};
      }
      ++result.compared;
    }
  result.mean = total / (3.0 * std::max(result.compared, 1));
  return result;
}

TEST_F(YarnRendererTest, StraightYarnHeadOnMatchesCpuShading) {
  // Shadows and fibre detail off: every covered pixel is the CPU shading of
  // the ellipse's normal its strip coordinate gives (no multisampling, so
  // each pixel is its centre's fragment).
  cloth::YarnSet set;
  set.style.radius_mm = 1;
  set.style.flatness = 0.6f;
  const Eigen::Vector3f colour(0.6f, 0.25f, 0.1f);
  set.curves.push_back(testing::straight_yarn(40, 81, 0, 0, 0.5f, colour));
  YarnRendererOptions options;
  options.shading.r_weight = 0.5f;  // strong lobes: their shape is held to too
  options.shading.tt_weight = 0.5f;
  auto renderer = make_renderer(options);
  auto target = make_target(0);
  ASSERT_TRUE(renderer && target);
  renderer->update(set);
  const KnitView view = plain_view(30);
  const cv::Mat frame = draw(*renderer, *target, view);
  const FibreSurface plain = plain_surface(set.style);
  const GoldenResult result = compare_straight_yarn(
      frame, *renderer, view, colour, 0.5f, -20, 0.95f,
      [&](float, float, const StripFrame&) { return plain; });
  ASSERT_GT(result.compared, 120 * 25) << "the yarn is about 33 pixels wide";
  // GL's float maths (exp, normalise, the interpolation between vertices)
  // and the sRGB rounding: a code or two.
  EXPECT_LE(result.worst, 2) << "worst at " << result.worst_at << ": got "
                             << frame.at<cv::Vec3b>(result.worst_at);
  EXPECT_LE(result.mean, 0.3);
}

TEST_F(YarnRendererTest, FibreDetailMatchesTheSliceOnTheCpu) {
  // Close enough that the slice is magnified (GL_LINEAR on level 0): each
  // pixel is the CPU twin with the slice sampled bilinearly there.
  cloth::YarnSet set;
  set.style.radius_mm = 1;
  set.style.flatness = 0.6f;
  const Eigen::Vector3f colour(0.7f, 0.6f, 0.45f);
  set.curves.push_back(testing::straight_yarn(6, 121, 0, 0, 1, colour));
  auto renderer = make_renderer();
  auto target = make_target(0);
  ASSERT_TRUE(renderer && target);
  renderer->update(set);
  KnitView view = plain_view(7);
  view.fibre_detail = true;
  const cv::Mat frame = draw(*renderer, *target, view);
  ASSERT_GT(renderer->last_yarn_width_px(), 100);
  const YarnSlice& slice = renderer->slice();
  const GoldenResult result = compare_straight_yarn(
      frame, *renderer, view, colour, 1, -3, 0.9f,
      [&](float across, float arc, const StripFrame& strip) {
        return slice_surface(sample_slice(slice, 0, slice_u(slice, across),
                                          slice_v(slice, arc) + strip.turn * renderer->style().twist_pitch_mm /
                                                                    slice.period_mm));
      });
  ASSERT_GT(result.compared, 2000);
  // The texture filter's 8-bit weights: a few codes at the plies' edges.
  EXPECT_LE(result.worst, 8) << "worst at " << result.worst_at;
  EXPECT_LE(result.mean, 0.8);
  // And the detail is there to be matched: the plies and grooves vary.
  cv::Mat grey;
  cv::cvtColor(frame(cv::Rect(100, 110, 120, 20)), grey, cv::COLOR_BGR2GRAY);
  cv::Scalar mean, deviation;
  cv::meanStdDev(grey, mean, deviation);
  EXPECT_GT(deviation[0], 8) << "plies, not a smooth tube";
}

TEST_F(YarnRendererTest, YarnLooksAsWideAsItsEllipseAndNothingElse) {
  for (const float flatness : {1.0f, 0.5f}) {
    cloth::YarnSet set;
    set.style.radius_mm = 0.8f;
    set.style.flatness = flatness;
    set.curves.push_back(testing::straight_yarn(40, 121));
    auto renderer = make_renderer();
    auto target = make_target();
    ASSERT_TRUE(renderer && target);
    renderer->update(set);
    // From above, then from 60 degrees down the yarn's side.
    for (const double pitch : {0.0, 60.0}) {
      KnitView view = plain_view(50);
      view.pitch_deg = pitch;
      const cv::Mat frame = draw(*renderer, *target, view);
      const KnitFrame setup = knit_frame(renderer->bounds(), view, kFrame);
      const StripFrame strip =
          strip_frame(Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitZ(), setup.eye,
                      set.style.radius_mm, flatness);
      const float expected = 2 * strip.half_width_mm * setup.focal_px / setup.distance;
      ASSERT_GT(expected, 5);
      const cv::Vec3b background = background_code(view);
      const float centre_row = setup.project(Eigen::Vector3f::Zero(), kFrame).y();
      int covered = 0;
      for (int row = 0; row < kFrame.height; ++row) {
        const cv::Vec3b pixel = frame.at<cv::Vec3b>(row, kFrame.width / 2);
        const float off_centre = std::abs(static_cast<float>(row) + 0.5f - centre_row);
        if (off_centre > expected / 2 + 1.5f)
          EXPECT_EQ(pixel, background) << "row " << row;
        else if (pixel != background)
          ++covered;
      }
      EXPECT_NEAR(covered, expected, 2.0) << "flatness " << flatness << ", pitch " << pitch;
    }
  }
}

TEST_F(YarnRendererTest, YarnUnderACrossingIsShadowedBesideIt) {
  // Light from +x, 60 degrees slant: the yarn in front shadows the one
  // behind over x from about -3.7 to -1 radii.
  const float radius = 1;
  const cloth::YarnSet set =
      testing::crossing_yarns(radius, 40, {0.5f, 0.5f, 0.5f}, {0.5f, 0.5f, 0.5f});
  auto renderer = make_renderer();
  auto target = make_target();
  ASSERT_TRUE(renderer && target);
  renderer->update(set);
  KnitView view = plain_view(35);
  view.light.tilt_deg = 0;
  view.light.slant_deg = 60;
  const auto beside_and_far = [&](bool shadows) {
    view.shadows = shadows;
    const cv::Mat frame = draw(*renderer, *target, view);
    EXPECT_EQ(renderer->last_drew_shadow_map(), shadows);
    const KnitFrame setup = knit_frame(renderer->bounds(), view, kFrame);
    const auto box = [&](float from_x, float to_x) {
      const Eigen::Vector2f a = setup.project({from_x, -0.3f * radius, -radius}, kFrame);
      const Eigen::Vector2f b = setup.project({to_x, 0.3f * radius, -radius}, kFrame);
      return cv::Rect(cv::Point(int(a.x()), int(b.y())), cv::Point(int(b.x()), int(a.y())));
    };
    const cv::Rect beside = box(-3.2f * radius, -1.5f * radius);
    const cv::Rect far = box(-9 * radius, -6 * radius);
    EXPECT_GT(beside.area(), 40);
    return std::pair{mean_grey(frame, beside), mean_grey(frame, far)};
  };
  const auto [shadowed_beside, shadowed_far] = beside_and_far(true);
  const auto [unshadowed_beside, unshadowed_far] = beside_and_far(false);
  const double with = shadowed_far - shadowed_beside;
  const double without = std::abs(unshadowed_far - unshadowed_beside);
  EXPECT_GT(with, 30) << "beside " << shadowed_beside << ", far " << shadowed_far;
  EXPECT_LT(without, 0.2 * with) << "beside " << unshadowed_beside << ", far " << unshadowed_far;
}

TEST_F(YarnRendererTest, YarnBetweenTheLayersIsDarker) {
  // Lift 1 at the ends, 0 in the middle (where it passes between layers),
  // against the same yarn at lift 1 throughout: all light scales by
  // crossing_light() (grey yarn, so any channel shows it).
  const auto lifted = [](float t) { return std::abs(2 * t - 1); };
  const Eigen::Vector3f grey(0.5f, 0.5f, 0.5f);
  auto renderer = make_renderer();
  auto target = make_target();
  ASSERT_TRUE(renderer && target);
  const KnitView view = plain_view(40);
  const auto linear_at = [&](const cloth::YarnCurve& curve, const std::vector<float>& xs) {
    cloth::YarnSet set;
    set.style.radius_mm = 1;
    set.curves.push_back(curve);
    renderer->update(set);
    const cv::Mat frame = draw(*renderer, *target, view);
    const KnitFrame setup = knit_frame(renderer->bounds(), view, kFrame);
    std::vector<float> values;
    for (const float x : xs) {
      const Eigen::Vector2f p = setup.project({x, 0, 0}, kFrame);
      const cv::Vec3b pixel = frame.at<cv::Vec3b>(int(p.y()), int(p.x()));
      values.push_back(srgb_decode(pixel[1] / 255.0f));
    }
    return values;
  };
  const std::vector<float> xs = {0, -12};
  const auto varying = linear_at(testing::straight_yarn_lifted(40, 161, 0, 0, lifted, grey), xs);
  const auto level = linear_at(testing::straight_yarn(40, 161, 0, 0, 1, grey), xs);
  const FibreShading shading;
  EXPECT_NEAR(varying[0] / level[0], crossing_light(0, shading), 0.02) << "lift 0 in the middle";
  EXPECT_NEAR(varying[1] / level[1], crossing_light(lifted(0.2f), shading), 0.02) << "lift 0.6";
  EXPECT_LT(varying[0], 0.7f * level[0]);
}

// The frame in linear light shrunk by `factor` (an area average): what a
// camera of that many fewer pixels would record.
cv::Mat shrunk(const cv::Mat& frame, int factor) {
  cv::Mat out;
  cv::resize(testing::linear_light(frame), out, frame.size() / factor, 0, 0, cv::INTER_AREA);
  return out;
}

// What aliasing leaves in a frame that its supersampled reference has not,
// inside `region` (the cloth's, away from its edges): the difference
// blurred, less its mean (moiré is a low-frequency beating of the fabric's
// repeat against the pixels; an even offset is a matter of the level of
// detail's brightness, measured apart), and the frame's own fine detail
// against the reference's (sparkle).
struct AliasingMeasure {
  double moire = 0;          // RMS of the blurred difference's variation, linear
  double sparkle_ratio = 0;  // RMS of (image - blur) of the frame over the reference's
  double mean_difference = 0;
};
AliasingMeasure measure_aliasing(const cv::Mat& frame_linear, const cv::Mat& reference_linear,
                                 const cv::Rect& region) {
  const auto grey = [](const cv::Mat& image) {
    cv::Mat out;
    cv::cvtColor(image, out, cv::COLOR_BGR2GRAY);
    return out;
  };
  const auto rms = [&](const cv::Mat& image) {
    cv::Scalar mean, deviation;
    cv::meanStdDev(image(region), mean, deviation);
    return std::sqrt(deviation[0] * deviation[0] + mean[0] * mean[0]);
  };
  AliasingMeasure measure;
  const cv::Mat frame = grey(frame_linear), reference = grey(reference_linear);
  const cv::Mat difference = frame - reference;
  cv::Mat blurred;
  cv::GaussianBlur(difference, blurred, cv::Size(), 2.5);
  cv::Scalar mean, deviation;
  cv::meanStdDev(blurred(region), mean, deviation);
  measure.moire = deviation[0];
  measure.mean_difference = std::abs(mean[0]);
  const auto fine = [&](const cv::Mat& image) {
    cv::Mat smooth;
    cv::GaussianBlur(image, smooth, cv::Size(), 1.0);
    return rms(image - smooth);
  };
  measure.sparkle_ratio = fine(frame) / std::max(fine(reference), 1e-6);
  return measure;
}

// The cloth's bounds as the frame shows them, shrunk by a fifth each way.
cv::Rect cloth_interior(const Eigen::AlignedBox3f& bounds, const KnitView& view, cv::Size size) {
  const KnitFrame frame = knit_frame(bounds, view, size);
  const Eigen::Vector2f a = frame.project(bounds.min(), size);
  const Eigen::Vector2f b = frame.project(bounds.max(), size);
  const cv::Rect2f box(cv::Point2f(std::min(a.x(), b.x()), std::min(a.y(), b.y())),
                       cv::Point2f(std::max(a.x(), b.x()), std::max(a.y(), b.y())));
  const cv::Rect2f inner(box.x + box.width / 5, box.y + box.height / 5, box.width * 3 / 5,
                         box.height * 3 / 5);
  return cv::Rect(inner) & cv::Rect(cv::Point(0, 0), size);
}

// A stockinette panel of `columns` x `rows` stitches as the knit geometry
// makes it.
cloth::YarnSet knitted_panel(int columns, int rows) {
  cloth::YarnSet yarns;
  const auto chart = cloth::load_stitch_chart(test::shipped_pattern("stockinette.chart"));
  EXPECT_TRUE(chart) << chart.error().describe();
  if (!chart) return yarns;
  auto fabric = cloth::KnitFabric::build(*chart, columns, rows, {});
  EXPECT_TRUE(fabric) << fabric.error().describe();
  if (fabric) fabric->update(fabric->mesh(), yarns);
  return yarns;
}

TEST_F(YarnRendererTest, FarViewHasNoAliasing) {
  // A stockinette panel as big as a garment's front looks from far enough
  // that its yarn is 0.8 and then 0.4 pixels wide in a 320x240 frame:
  // stitches under two pixels, the loops' legs and the courses past the
  // pixels' Nyquist limit. Against the same views drawn 8x as large and
  // shrunk (64 times the samples): the far view's level of detail (the
  // stitch mesh textured with the repeat baked at the near level) must
  // leave no beating, be no noisier than the same renderer supersampled 2x,
  // and keep the cloth's brightness.
  const cloth::YarnSet set = knitted_panel(140, 160);
  KnitView view;
  view.light.tilt_deg = 30;
  view.light.slant_deg = 50;
  const auto render = [&](const YarnRendererOptions& options, cv::Size size) {
    auto renderer = make_renderer(options);
    auto target = make_target(4, size);
    EXPECT_TRUE(renderer && target);
    renderer->update(set);
    return draw(*renderer, *target, view);
  };
  const YarnRendererOptions options;
  YarnRendererOptions unfiltered = options;  // strips at the yarns' own width
  unfiltered.prefilter_px = 0;
  unfiltered.far_cloth_from_px = 0;  // no textured far level
  const float focal_px = knit_frame(set.bounds(), view, kFrame).focal_px;
  for (const double yarn_px : {0.8, 0.4}) {
    view.distance_mm = 2 * set.style.radius_mm * focal_px / yarn_px;
    const cv::Rect region = cloth_interior(set.bounds(), view, kFrame);
    ASSERT_GT(region.area(), 2000);
    const cv::Mat reference = shrunk(render(options, kFrame * 8), 8);
    const AliasingMeasure far = measure_aliasing(testing::linear_light(render(options, kFrame)), reference, region);
    const AliasingMeasure twice =
        measure_aliasing(shrunk(render(options, kFrame * 2), 2), reference, region);
    EXPECT_LT(far.moire, 0.006) << "beating against the pixel grid, yarn " << yarn_px << " px";
    EXPECT_LT(far.sparkle_ratio, 1.3 * twice.sparkle_ratio)
        << "noisier than supersampled, yarn " << yarn_px << " px";
    EXPECT_LT(far.mean_difference, 0.03) << "the cloth's brightness, yarn " << yarn_px << " px";
    if (yarn_px > 0.5) continue;
    // The measures catch aliasing where there is some: the same yarns'
    // strips at their own width (a third of a pixel), samples hit or missed.
    const AliasingMeasure aliased =
        measure_aliasing(testing::linear_light(render(unfiltered, kFrame)), reference, region);
    EXPECT_TRUE(aliased.moire >= 0.006 || aliased.sparkle_ratio >= 1.3 * twice.sparkle_ratio)
        << "moire " << aliased.moire << ", sparkle " << aliased.sparkle_ratio;
  }
}

TEST_F(YarnRendererTest, LevelsOfDetailBlendWithoutPopping) {
  // A small stockinette panel drawn ever larger, each frame shrunk back to
  // one small size and softened (what stays of it is its look, not its
  // pixels): the yarns grow from under a pixel to a dozen across, through
  // the textured far level alone, the yarns growing in over it (2.5 to 5
  // px), the near detail growing in, the halo and the shadow map taking over. Each step to the
  // next size changes the shrunk frame about as much as the last: no step
  // jumps.
  const cloth::YarnSet set = knitted_panel(40, 46);
  auto renderer = make_renderer();
  ASSERT_TRUE(renderer);
  renderer->update(set);
  KnitView view;
  view.light.tilt_deg = 30;
  view.light.slant_deg = 50;
  const cv::Size small(64, 48);
  const cv::Rect region = cloth_interior(set.bounds(), view, small);
  cv::Mat previous;
  std::vector<double> steps;
  std::vector<float> widths;
  bool prefiltered = false, far_only = false, near = false, halo = false, map = false;
  bool far_cloth = false, cross_faded = false;
  for (double width = 64; width <= 1600; width *= 1.06) {
    const cv::Size size(static_cast<int>(width) / 4 * 4, static_cast<int>(width * 0.75) / 4 * 4);
    auto target = make_target(4, size);
    ASSERT_TRUE(target);
    cv::Mat frame;
    cv::resize(testing::linear_light(draw(*renderer, *target, view)), frame, small, 0, 0, cv::INTER_AREA);
    cv::GaussianBlur(frame, frame, cv::Size(), 2.0);
    const float yarn_px = renderer->last_yarn_width_px();
    prefiltered |= yarn_px < renderer->options().prefilter_from_px;
    far_only |= renderer->last_drew_far_only();
    near |= !renderer->last_drew_far_only();
    halo |= renderer->last_drew_halo();
    map |= renderer->last_drew_shadow_map();
    far_cloth |= renderer->last_drew_far_cloth() && !renderer->last_drew_yarns();
    cross_faded |= renderer->last_drew_far_cloth() && renderer->last_drew_yarns();
    if (!previous.empty()) {
      cv::Mat difference;
      cv::absdiff(frame(region), previous(region), difference);
      const cv::Scalar mean = cv::mean(difference);
      steps.push_back((mean[0] + mean[1] + mean[2]) / 3);
      widths.push_back(yarn_px);
    }
    previous = frame;
  }
  ASSERT_TRUE(prefiltered && far_only && near && halo && map && far_cloth && cross_faded)
      << "the sweep crosses every change of detail";
  std::vector<double> sorted = steps;
  std::sort(sorted.begin(), sorted.end());
  const double median = sorted[sorted.size() / 2];
  for (std::size_t k = 0; k < steps.size(); ++k)
    EXPECT_LT(steps[k], 3 * median + 0.002)
        << "step " << k << " of " << steps.size() << " to yarns " << widths[k]
        << " px wide (median step " << median << ")";
}

TEST_F(YarnRendererTest, FarFramesDrawNoShadowMapNearOnesDo) {
  const cloth::YarnSet set = testing::wavy_grid(12, 40, 2, 0.6f);
  auto renderer = make_renderer();
  auto target = make_target();
  ASSERT_TRUE(renderer && target);
  renderer->update(set);
  KnitView view = plain_view(60);
  view.shadows = true;
  view.fibre_detail = true;
  draw(*renderer, *target, view);
  EXPECT_GE(renderer->last_yarn_width_px(), 5);
  EXPECT_TRUE(renderer->last_drew_shadow_map());
  EXPECT_TRUE(renderer->last_drew_halo());
  EXPECT_FALSE(renderer->last_drew_far_only());

  view.distance_mm = 1500;
  const cv::Mat far = draw(*renderer, *target, view);
  EXPECT_LE(renderer->last_yarn_width_px(), 1);
  EXPECT_FALSE(renderer->last_drew_halo());
  EXPECT_TRUE(renderer->last_drew_far_only());
  const cv::Vec3b background = background_code(view);
  int covered = 0;
  for (int row = 0; row < far.rows; ++row)
    for (int col = 0; col < far.cols; ++col)
      covered += far.at<cv::Vec3b>(row, col) != background;
  EXPECT_GT(covered, 30) << "the far fabric still shows";

  // A panel whose yarns are a texel or two in a map as fine as the screen:
  // statistical shadows, no map.
  renderer->update(knitted_panel(60, 60));
  view.distance_mm = 0;
  draw(*renderer, *target, view);
  EXPECT_FALSE(renderer->last_drew_shadow_map());
}

TEST_F(YarnRendererTest, FrontAndBackDiffer) {
  // Red in front of blue: from behind (yaw 180) blue covers the crossing.
  const cloth::YarnSet set =
      testing::crossing_yarns(1, 30, {0.05f, 0.1f, 0.8f}, {0.8f, 0.1f, 0.05f});
  auto renderer = make_renderer();
  auto target = make_target();
  ASSERT_TRUE(renderer && target);
  renderer->update(set);
  KnitView view = plain_view(40);
  view.shadows = true;
  view.light.slant_deg = 0;
  const cv::Mat front = draw(*renderer, *target, view);
  view.yaw_deg = 180;
  view.light.slant_deg = 180;  // lit from behind too
  const cv::Mat back = draw(*renderer, *target, view);
  const cv::Vec3b front_centre = front.at<cv::Vec3b>(kFrame.height / 2, kFrame.width / 2);
  const cv::Vec3b back_centre = back.at<cv::Vec3b>(kFrame.height / 2, kFrame.width / 2);
  EXPECT_GT(front_centre[2], front_centre[0] + 50) << "red in front: " << front_centre;
  EXPECT_GT(back_centre[0], back_centre[2] + 50) << "blue behind: " << back_centre;
}

TEST_F(YarnRendererTest, UpdateMovesTheYarnsAndKeepsItsBuffer) {
  cloth::YarnSet set = testing::wavy_grid(6, 30, 3, 0.6f);
  auto renderer = make_renderer();
  auto target = make_target();
  ASSERT_TRUE(renderer && target);
  renderer->update(set);
  KnitView view = plain_view(0);
  view.shadows = true;
  const cv::Mat before = draw(*renderer, *target, view);
  EXPECT_EQ(renderer->buffer_allocations(), 1);
  EXPECT_EQ(renderer->slice_bakes(), 1) << "the default style's slice, baked at creation";

  // One point of one yarn pushed sideways, inside the bounds: the camera
  // stays, the yarn bends there.
  cloth::YarnCurve& moved = set.curves[2];
  moved.points[moved.points.size() / 2].y() += 1.2f;
  renderer->update(set);
  EXPECT_EQ(renderer->buffer_allocations(), 1) << "same point count: rewritten in place";
  const cv::Mat after = draw(*renderer, *target, view);
  cv::Mat difference, changed;
  cv::absdiff(before, after, difference);
  cv::cvtColor(difference, difference, cv::COLOR_BGR2GRAY);
  cv::threshold(difference, changed, 30, 1, cv::THRESH_BINARY);
  EXPECT_GT(cv::countNonZero(changed), 20) << "the bend shows";

  renderer->update(set);
  const cv::Mat again = draw(*renderer, *target, view);
  cv::absdiff(after, again, difference);
  EXPECT_EQ(cv::countNonZero(difference.reshape(1)), 0) << "the same set draws the same frame";

  set.curves.pop_back();
  renderer->update(set);
  EXPECT_EQ(renderer->buffer_allocations(), 2);
  set.style.plies = 3;
  renderer->update(set);
  EXPECT_EQ(renderer->slice_bakes(), 2) << "a new look bakes a new slice";
  set.style.colour = {0.1f, 0.2f, 0.3f};
  renderer->update(set);
  EXPECT_EQ(renderer->slice_bakes(), 2) << "a new colour does not";
}

TEST_F(YarnRendererTest, EmptySetDrawsBackground) {
  auto renderer = make_renderer();
  auto target = make_target();
  ASSERT_TRUE(renderer && target);
  renderer->update(cloth::YarnSet{});
  const KnitView view = plain_view(0);
  const cv::Mat frame = draw(*renderer, *target, view);
  EXPECT_EQ(frame.at<cv::Vec3b>(10, 10), background_code(view));
}

}  // namespace
}  // namespace psrig::preview
