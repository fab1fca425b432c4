// The preview's geometry: Bezier patch tangent frames against finite
// differences, the maps tiling at their physical size, and the scene's
// axes (light tilt 0 comes from +x, the camera looks down -z).

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "psrig/cloth/bezier_patch.h"
#include "psrig/preview/scene_view.h"

namespace psrig::preview {
namespace {

TEST(BezierPatch, AnalyticDerivativesMatchFiniteDifferences) {
  const cloth::BezierPatch patch = cloth::BezierPatch::make(cloth::PatchShape::draped, {32, 24});
  constexpr float h = 1e-3f;
  for (const float u : {0.1f, 0.5f, 0.83f})
    for (const float v : {0.2f, 0.5f, 0.9f}) {
      const Eigen::Vector3f du = (patch.position(u + h, v) - patch.position(u - h, v)) / (2 * h);
      const Eigen::Vector3f dv = (patch.position(u, v + h) - patch.position(u, v - h)) / (2 * h);
      EXPECT_LT((patch.d_du(u, v) - du).norm(), 1e-2f * du.norm()) << u << "," << v;
      EXPECT_LT((patch.d_dv(u, v) - dv).norm(), 1e-2f * dv.norm()) << u << "," << v;
    }
}

TEST(BezierPatch, DrapedSheetIsCurvedFlatOneIsNot) {
  const cloth::BezierPatch flat = cloth::BezierPatch::make(cloth::PatchShape::flat, {30, 20});
  const cloth::BezierPatch draped = cloth::BezierPatch::make(cloth::PatchShape::draped, {30, 20});
  EXPECT_NEAR(flat.position(0.3f, 0.7f).z(), 0, 1e-5);
  EXPECT_NEAR(flat.position(0, 0).x(), -15, 1e-4);
  EXPECT_NEAR(flat.position(1, 1).y(), 10, 1e-4);
  EXPECT_GT(std::abs(draped.position(0.3f, 0.2f).z()), 1.0f);
}

TEST(BezierPatch, TessellationCarriesOrthonormalFramesAndTiles) {
  const cv::Size2d extent(40, 30), tile(20, 15);
  const cloth::PatchMesh mesh = cloth::tessellate(cloth::BezierPatch::make(cloth::PatchShape::draped, extent), 8, extent, tile);
  ASSERT_EQ(mesh.vertices.size(), 81u);
  EXPECT_EQ(mesh.indices.size(), 8u * 8u * 6u);
  for (const cloth::PatchVertex& vertex : mesh.vertices) {
    const Eigen::Vector3f n(vertex.normal), t(vertex.tangent), b(vertex.bitangent);
    EXPECT_NEAR(n.norm(), 1, 1e-5);
    EXPECT_NEAR(t.norm(), 1, 1e-5);
    EXPECT_NEAR(n.dot(t), 0, 1e-5);
    EXPECT_NEAR(b.dot(n.cross(t)), 1, 1e-5);  // right-handed: b = n x t
    EXPECT_GT(n.z(), 0.3f);                   // the sheet faces the camera
  }
  // Two tiles across each way: u from -0.5 to 1.5 about the middle.
  EXPECT_NEAR(mesh.vertices.front().uv[0], -0.5f, 1e-5);
  EXPECT_NEAR(mesh.vertices.back().uv[0], 1.5f, 1e-5);
  EXPECT_NEAR(mesh.vertices.back().uv[1], 1.5f, 1e-5);
}

TEST(SceneView, LightOfTiltZeroComesFromPlusX) {
  SceneView view;
  view.light = {LightKind::directional, 0, 30, 1};
  const FrameSetup setup = frame_setup({10, 10}, view, {100, 100});
  EXPECT_NEAR(setup.light.x(), 0.5f, 1e-6);
  EXPECT_NEAR(setup.light.y(), 0.0f, 1e-6);
  EXPECT_NEAR(setup.light.z(), std::sqrt(3.0f) / 2, 1e-6);
  EXPECT_EQ(setup.light.w(), 0.0f);  // a direction
  view.light.kind = LightKind::point;
  const FrameSetup point = frame_setup({10, 10}, view, {100, 100});
  EXPECT_EQ(point.light.w(), 1.0f);
  EXPECT_NEAR(point.light.head<3>().norm(), point.light_reference_distance, 1e-4);
}

TEST(SceneView, FlatViewMapsTheSwatchOntoTheFrame) {
  // The swatch's corners land on the frame's corners: +x right, +y up.
  const SceneView view;
  const FrameSetup setup = frame_setup({40, 30}, view, {400, 300});
  const Eigen::Matrix4f to_clip = setup.projection * setup.view * setup.model;
  const Eigen::Vector4f top_right = to_clip * Eigen::Vector4f(20, 15, 0, 1);
  EXPECT_NEAR(top_right.x() / top_right.w(), 1, 1e-5);
  EXPECT_NEAR(top_right.y() / top_right.w(), 1, 1e-5);
  // A wider frame letterboxes instead of stretching.
  const FrameSetup wide = frame_setup({40, 30}, view, {800, 300});
  const Eigen::Vector4f corner =
      wide.projection * wide.view * wide.model * Eigen::Vector4f(20, 15, 0, 1);
  EXPECT_NEAR(corner.x() / corner.w(), 0.5, 1e-5);
  EXPECT_NEAR(corner.y() / corner.w(), 1, 1e-5);
}

TEST(SceneView, PatchViewKeepsTheWholeSheetInFrame) {
  SceneView view;
  view.kind = ViewKind::patch;
  view.camera_pitch_deg = 30;
  view.camera_yaw_deg = 15;
  for (const cv::Size viewport : {cv::Size(1920, 1080), cv::Size(480, 800)}) {
    const FrameSetup setup = frame_setup({16, 12}, view, viewport);
    const Eigen::Matrix4f to_clip = setup.projection * setup.view * setup.model;
    const cloth::BezierPatch patch = cloth::BezierPatch::make(setup.shape, setup.patch_extent);
    for (const float u : {0.0f, 1.0f})
      for (const float v : {0.0f, 1.0f}) {
        const Eigen::Vector4f clip = to_clip * patch.position(u, v).homogeneous();
        EXPECT_LT(std::abs(clip.x() / clip.w()), 1) << viewport;
        EXPECT_LT(std::abs(clip.y() / clip.w()), 1) << viewport;
      }
  }
}

}  // namespace
}  // namespace psrig::preview
