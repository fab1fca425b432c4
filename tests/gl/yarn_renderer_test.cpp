// The GLES yarn renderer on Mesa's llvmpipe: a straight yarn held to the
// CPU shading pixel by pixel, its width, shadows where yarns cross, the
// level of detail, and updates.

#include "psrig/preview/yarn_renderer.h"

#include <GLES3/gl3.h>

#include <Eigen/LU>
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "psrig/preview/egl_context.h"
#include "psrig/preview/offscreen_target.h"
#include "psrig/preview/shading.h"
#include "psrig/preview/texture_levels.h"
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

  std::unique_ptr<OffscreenTarget> make_target(int samples = 4) {
    auto target = OffscreenTarget::create(kFrame, samples, ColourStorage::srgb);
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

TEST_F(YarnRendererTest, StraightYarnHeadOnMatchesCpuShading) {
  // Shadows and fibre detail off: every covered pixel is the CPU shading of
  // the tube normal its strip coordinate gives (no multisampling, so each
  // pixel is its centre's fragment).
  cloth::YarnSet set;
  set.style.radius_mm = 1;
  const Eigen::Vector3f colour(0.6f, 0.25f, 0.1f);
  set.curves.push_back(testing::straight_yarn(40, 81, 0, 0, 0.5f, colour));
  YarnRendererOptions options;
  options.shading.primary_specular = 0.5f;  // strong lobes: their shape is held to too
  options.shading.secondary_specular = 0.5f;
  auto renderer = make_renderer(options);
  auto target = make_target(0);
  ASSERT_TRUE(renderer && target);
  renderer->update(set);
  const KnitView view = plain_view(30);
  const cv::Mat frame = draw(*renderer, *target, view);
  const KnitFrame setup = knit_frame(renderer->bounds(), view, kFrame);

  const Eigen::Vector3f tangent = Eigen::Vector3f::UnitX();
  const float helix = ply_helix_angle(set.style);
  const float light_scale = crossing_light(0.5f, options.shading);
  int compared = 0, worst = 0;
  double total = 0;
  cv::Point worst_at;
  for (int row = 0; row < kFrame.height; ++row)
    for (int col = 100; col < 220; ++col) {
      const Eigen::Vector3f strip = unproject(setup, kFrame, col + 0.5f, row + 0.5f, 0);
      const Eigen::Vector3f to_eye = setup.eye - strip;
      const Eigen::Vector3f side = tangent.cross(to_eye).normalized();
      const float across = side.dot(strip - Eigen::Vector3f(strip.x(), 0, 0)) / 1.0f;
      if (std::abs(across) > 0.95f) continue;  // the edge: no normal to speak of
      const Eigen::Vector3f normal = tube_normal(tangent, to_eye, across);
      const FibrePoint point{fibre_tangent(tangent, normal, helix), normal, colour, light_scale};
      const Eigen::Vector3f linear =
          shade_fibres(point, setup.light.head<3>(), to_eye, 1, 1, options.shading);
      const cv::Vec3b expected(srgb8(linear[2]), srgb8(linear[1]), srgb8(linear[0]));
      const cv::Vec3b got = frame.at<cv::Vec3b>(row, col);
      for (int c = 0; c < 3; ++c) {
        const int difference = std::abs(int(got[c]) - int(expected[c]));
        total += difference;
        if (difference > worst) worst = difference, worst_at = {col, row};
      }
      ++compared;
    }
  ASSERT_GT(compared, 120 * 25) << "the yarn is about 33 pixels wide";
  // GL's float maths (pow, normalise) and the sRGB rounding: a code or two.
  EXPECT_LE(worst, 2) << "worst at " << worst_at << ": got " << frame.at<cv::Vec3b>(worst_at);
  EXPECT_LE(total / (3.0 * compared), 0.3);
}

TEST_F(YarnRendererTest, YarnCoversTwoRadiiAcrossAndNothingElse) {
  cloth::YarnSet set;
  set.style.radius_mm = 0.8f;
  set.curves.push_back(testing::straight_yarn(40, 121));
  auto renderer = make_renderer();
  auto target = make_target();
  ASSERT_TRUE(renderer && target);
  renderer->update(set);
  const KnitView view = plain_view(50);
  const cv::Mat frame = draw(*renderer, *target, view);
  const KnitFrame setup = knit_frame(renderer->bounds(), view, kFrame);
  const float expected = 2 * set.style.radius_mm * setup.focal_px / setup.distance;
  ASSERT_GT(expected, 10);
  const cv::Vec3b background = background_code(view);
  const float centre_row = setup.project(Eigen::Vector3f::Zero(), kFrame).y();
  for (const int col : {60, 160, 260}) {
    int covered = 0;
    for (int row = 0; row < kFrame.height; ++row) {
      const cv::Vec3b pixel = frame.at<cv::Vec3b>(row, col);
      const float off_centre = std::abs(static_cast<float>(row) + 0.5f - centre_row);
      if (off_centre > expected / 2 + 1.5f)
        EXPECT_EQ(pixel, background) << "row " << row << " col " << col;
      else if (pixel != background)
        ++covered;
    }
    EXPECT_NEAR(covered, expected, 2.0) << "col " << col;
  }
}

TEST_F(YarnRendererTest, YarnUnderACrossingIsShadowedBesideIt) {
  // Light from +x, 60 degrees slant: the yarn in front shadows the one
  // behind over x from about -3.7 to -1 radii.
  const float radius = 1;
  const cloth::YarnSet set = testing::crossing_yarns(radius, 40, {0.5f, 0.5f, 0.5f}, {0.5f, 0.5f, 0.5f});
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

TEST_F(YarnRendererTest, FarViewDrawsLinesNearViewTubesBlendedBetween) {
  const cloth::YarnSet set = testing::wavy_grid(12, 40, 2, 0.6f);
  auto renderer = make_renderer();
  auto target = make_target();
  ASSERT_TRUE(renderer && target);
  renderer->update(set);
  KnitView view = plain_view(0);
  view.shadows = true;
  view.fibre_detail = true;
  const cv::Vec3b background = background_code(view);
  const auto covered = [&](const cv::Mat& frame) {
    int count = 0;
    for (int row = 0; row < frame.rows; ++row)
      for (int col = 0; col < frame.cols; ++col)
        count += frame.at<cv::Vec3b>(row, col) != background;
    return count;
  };

  view.distance_mm = 60;
  draw(*renderer, *target, view);
  EXPECT_GE(renderer->last_yarn_width_px(), 3);
  EXPECT_EQ(renderer->last_tube_weight(), 1);

  view.distance_mm = 1500;
  const cv::Mat far = draw(*renderer, *target, view);
  EXPECT_LE(renderer->last_yarn_width_px(), 1);
  EXPECT_EQ(renderer->last_tube_weight(), 0);
  EXPECT_GT(covered(far), 30) << "the far fabric still shows, as lines";

  view.distance_mm = 270;
  const cv::Mat between = draw(*renderer, *target, view);
  EXPECT_GT(renderer->last_tube_weight(), 0.1f);
  EXPECT_LT(renderer->last_tube_weight(), 0.9f);
  EXPECT_GT(covered(between), 1000);

  // The blend has no seam: just either side of each end of the band the
  // frames barely differ.
  for (const double distance : {1.0 / 3.0, 1.0}) {
    const double px_distance = 2 * 0.6 * knit_frame(renderer->bounds(), view, kFrame).focal_px;
    view.distance_mm = px_distance * distance / 1.01;
    const cv::Mat a = draw(*renderer, *target, view);
    view.distance_mm = px_distance * distance / 0.99;
    const cv::Mat b = draw(*renderer, *target, view);
    cv::Mat difference;
    cv::absdiff(a, b, difference);
    EXPECT_LT(cv::mean(difference)[1], 2.0) << "at a yarn " << 1 / distance << " px wide";
  }
}

TEST_F(YarnRendererTest, FrontAndBackDiffer) {
  // Red in front of blue: from behind (yaw 180) blue covers the crossing.
  const cloth::YarnSet set = testing::crossing_yarns(1, 30, {0.05f, 0.1f, 0.8f}, {0.8f, 0.1f, 0.05f});
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
