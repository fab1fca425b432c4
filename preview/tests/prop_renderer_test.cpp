// What a drape's cloth meets, drawn under the yarns (prop_renderer.h): the
// meshes lie on the colliders' surfaces with outward normals, and inside
// the yarn renderer's frame they are depth-tested against the yarns: a
// ball in front of a yarn hides it, one behind it is hidden.

#include "psrig/preview/prop_renderer.h"

#include <GLES3/gl3.h>

#include <gtest/gtest.h>

#include "psrig/preview/egl_context.h"
#include "psrig/preview/offscreen_target.h"
#include "psrig/preview/yarn_renderer.h"
#include "yarn_fixture.h"

namespace psrig::preview {
namespace {

TEST(PropMesh, EveryVertexLiesOnItsColliderWithTheNormalOutward) {
  const cloth::SphereCollider sphere{{1, 2, 3}, 7};
  const cloth::CapsuleCollider arm{{-20, 0, 0}, {20, 0, 0}, 5};
  const cloth::BoxCollider table{{-10, -5, -10}, {10, 0, 0}};
  const std::vector<cloth::Collider> colliders{sphere, arm, table};
  const PropMesh mesh = prop_mesh(colliders, {0, 0, 0}, 100);
  ASSERT_EQ(mesh.positions.size(), mesh.normals.size());
  ASSERT_EQ(mesh.positions.size() % 3, 0u);
  EXPECT_EQ(mesh.solid_vertices, mesh.positions.size());  // no plane
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    const std::size_t first = i - i % 3;
    const Eigen::Vector3f centroid =
        (mesh.positions[first] + mesh.positions[first + 1] + mesh.positions[first + 2]) / 3;
    // A hair inside its triangle, off a box's edges, where its face's
    // normal is the surface's.
    const Eigen::Vector3f p = mesh.positions[i] + 0.01f * (centroid - mesh.positions[i]);
    const Eigen::Vector3f& n = mesh.normals[i];
    EXPECT_NEAR(n.norm(), 1, 1e-4);
    // On the surface of one of them, the normal pointing out of it there.
    bool on_one = false;
    for (const cloth::Collider& collider : colliders) {
      const cloth::SurfacePoint surface = cloth::nearest_surface(collider, p);
      if (std::abs(surface.distance) < 1e-2f && surface.normal.dot(n) > 0.99f) on_one = true;
    }
    EXPECT_TRUE(on_one) << "vertex " << i << " at " << p.transpose();
  }
}

TEST(PropMesh, AFloorIsASquareUnderTheCentre) {
  const cloth::PlaneCollider floor{{0, -30, 0}, {0, 1, 0}};
  const PropMesh mesh = prop_mesh({floor}, {5, 10, -4}, 200);
  ASSERT_EQ(mesh.positions.size(), 6u);
  EXPECT_EQ(mesh.solid_vertices, 0u);
  Eigen::AlignedBox3f box;
  for (const Eigen::Vector3f& p : mesh.positions) box.extend(p);
  EXPECT_NEAR(box.sizes().x(), 200, 1e-3);
  EXPECT_NEAR(box.sizes().z(), 200, 1e-3);
  EXPECT_NEAR(box.center().y(), -30, 1e-4);
  EXPECT_NEAR(box.center().x(), 5, 1e-3);
  EXPECT_NEAR(box.center().z(), -4, 1e-3);
  for (const Eigen::Vector3f& n : mesh.normals) EXPECT_NEAR(n.y(), 1, 1e-6);
}

// A red yarn along x at z = 0, seen head on, and a grey ball over its
// middle, in front (z > 0) or behind (z < 0).
cv::Vec3b middle_pixel(float ball_z) {
  auto context = EglContext::open_surfaceless();
  EXPECT_TRUE(context) << context.error().describe();
  if (!context) return {};
  const cv::Size size(160, 120);
  auto target = OffscreenTarget::create(size, 4, ColourStorage::srgb);
  auto yarns = YarnRenderer::create();
  auto props = PropRenderer::create();
  EXPECT_TRUE(target && yarns && props);
  if (!target || !yarns || !props) return {};
  cloth::YarnSet set;
  set.style.radius_mm = 1;
  set.curves.push_back(testing::straight_yarn(20, 81));
  (*yarns)->update(set);
  (*props)->update({cloth::SphereCollider{{0, 0, ball_z}, 2}}, {0, 0, 0}, 100);
  (*target)->bind();
  KnitView view;
  (*yarns)->render(view, size, [&](const KnitFrame& frame) { (*props)->draw(frame); });
  EXPECT_EQ(glGetError(), static_cast<GLenum>(GL_NO_ERROR));
  const cv::Mat image = (*target)->read();
  return image.at<cv::Vec3b>(size.height / 2, size.width / 2);
}

TEST(PropRenderer, DepthTestedAgainstTheYarns) {
  const cv::Vec3b in_front = middle_pixel(5), behind = middle_pixel(-5);
  // BGR: the ball is grey, the yarn red.
  const auto reddish = [](cv::Vec3b p) { return p[2] > p[1] + 40 && p[2] > p[0] + 40; };
  const auto greyish = [](cv::Vec3b p) {
    return std::abs(p[2] - p[0]) < 25 && std::abs(p[1] - p[0]) < 25 && p[0] > 60;
  };
  EXPECT_TRUE(greyish(in_front)) << in_front;
  EXPECT_TRUE(reddish(behind)) << behind;
}

}  // namespace
}  // namespace psrig::preview
