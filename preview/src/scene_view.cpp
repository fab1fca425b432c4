#include "psrig/preview/scene_view.h"

#include <cmath>
#include <numbers>

#include <Eigen/Geometry>

#include "camera_matrices.h"
#include "psrig/formats/light_matrix.h"

namespace psrig::preview {
namespace {

Eigen::Matrix4f rotation(const Eigen::Matrix3f& turn) {
  Eigen::Matrix4f m = Eigen::Matrix4f::Identity();
  m.topLeftCorner<3, 3>() = turn;
  return m;
}

}  // namespace

FrameSetup frame_setup(cv::Size2d swatch_extent, const SceneView& view, cv::Size viewport) {
  FrameSetup setup;
  const bool flat = view.kind == ViewKind::flat;
  setup.shape = flat ? cloth::PatchShape::flat : cloth::PatchShape::draped;
  const double tiles = flat ? 1.0 : kDrapedTiles;
  setup.patch_extent = {swatch_extent.width * tiles, swatch_extent.height * tiles};
  const auto diagonal =
      static_cast<float>(std::hypot(setup.patch_extent.width, setup.patch_extent.height));

  setup.model = rotation(yaw_pitch(view.model_yaw_deg, view.model_pitch_deg));
  const Eigen::Matrix3f orbit = yaw_pitch(view.camera_yaw_deg, -view.camera_pitch_deg);
  const float aspect = static_cast<float>(viewport.width) / static_cast<float>(viewport.height);
  const float zoom = static_cast<float>(std::max(view.zoom, 1e-3));
  const Eigen::Vector3f back = orbit * Eigen::Vector3f::UnitZ();
  const Eigen::Vector3f up = orbit * Eigen::Vector3f::UnitY();
  if (flat) {
    // Orthographic, the swatch (plus margin) fitted to the frame.
    const auto border = static_cast<float>(1 + 2 * view.margin);
    float half_width = static_cast<float>(setup.patch_extent.width) / 2 * border;
    float half_height = static_cast<float>(setup.patch_extent.height) / 2 * border;
    if (half_width / half_height < aspect)
      half_width = half_height * aspect;
    else
      half_height = half_width / aspect;
    const Eigen::Vector3f eye = back * (2 * diagonal);
    setup.view = look_at(eye, Eigen::Vector3f::Zero(), up);
    setup.projection =
        orthographic(half_width / zoom, half_height / zoom, 0.01f * diagonal, 4 * diagonal);
    setup.eye << back, 0;
  } else {
    const float fov_y = radians(30);
    // Far enough back for the patch's bounding sphere to fit either way.
    const float fit = (diagonal / 2) / std::sin(fov_y / 2) / std::min(aspect, 1.0f);
    const Eigen::Vector3f eye = back * (fit / zoom);
    setup.view = look_at(eye, Eigen::Vector3f::Zero(), up);
    setup.projection = perspective(fov_y, aspect, 0.02f * fit, 4 * fit);
    setup.eye << eye, 1;
  }

  const cv::Vec3d l = formats::light_direction(view.light.tilt_deg, view.light.slant_deg);
  const Eigen::Vector3f toward(static_cast<float>(l[0]), static_cast<float>(l[1]),
                               static_cast<float>(l[2]));
  setup.marker_radius = 0.03f * diagonal;
  if (view.light.kind == LightKind::point) {
    setup.light_reference_distance = static_cast<float>(view.light.distance) * diagonal;
    setup.marker_centre = toward * setup.light_reference_distance;
    setup.light << setup.marker_centre, 1;
  } else {
    setup.marker_centre = toward * (0.6f * diagonal);
    setup.light << toward, 0;
  }
  return setup;
}

}  // namespace psrig::preview
