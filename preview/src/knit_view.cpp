#include "psrig/preview/knit_view.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "camera_matrices.h"
#include "psrig/formats/light_matrix.h"

namespace psrig::preview {
Eigen::Vector2f KnitFrame::project(const Eigen::Vector3f& point, cv::Size viewport) const {
  const Eigen::Vector4f clip = projection * view * point.homogeneous();
  return {(clip.x() / clip.w() + 1) / 2 * static_cast<float>(viewport.width),
          (1 - clip.y() / clip.w()) / 2 * static_cast<float>(viewport.height)};
}

KnitFrame knit_frame(const Eigen::AlignedBox3f& bounds, const KnitView& view, cv::Size viewport) {
  KnitFrame frame;
  const bool empty = bounds.isEmpty();
  frame.centre = empty ? Eigen::Vector3f::Zero().eval() : bounds.center().eval();
  const float radius = empty ? 1.0f : std::max(bounds.diagonal().norm() / 2, 1e-3f);

  const Eigen::Matrix3f orbit = yaw_pitch(view.yaw_deg, -view.pitch_deg);
  const float aspect = static_cast<float>(viewport.width) / static_cast<float>(viewport.height);
  const float fov_y = radians(std::clamp(view.fov_y_deg, 1.0, 150.0));
  // Fitting: the bounding sphere inside the narrower of the two angles.
  const float fit = radius / std::sin(fov_y / 2) / std::min(aspect, 1.0f);
  frame.distance = view.distance_mm > 0 ? static_cast<float>(view.distance_mm) : fit;
  frame.eye = frame.centre + orbit * Eigen::Vector3f::UnitZ() * frame.distance;
  frame.view = look_at(frame.eye, frame.centre, orbit * Eigen::Vector3f::UnitY());
  const float near = std::max(frame.distance - radius, 0.01f * frame.distance);
  frame.projection = perspective(fov_y, aspect, near, frame.distance + radius);
  frame.focal_px = static_cast<float>(viewport.height) / 2 / std::tan(fov_y / 2);

  const cv::Vec3d l = formats::light_direction(view.light.tilt_deg, view.light.slant_deg);
  const Eigen::Vector3f toward(static_cast<float>(l[0]), static_cast<float>(l[1]),
                               static_cast<float>(l[2]));
  if (view.light.kind == LightKind::point) {
    frame.light_reference_distance = static_cast<float>(view.light.distance) * 2 * radius;
    frame.light << frame.centre + toward * frame.light_reference_distance, 1;
  } else {
    frame.light << toward, 0;
  }
  // A point light's shadow is taken as a directional one from where it
  // stands: an orthographic map fitted to the bounds covers it all.
  frame.toward_shadow_light = toward;
  const Eigen::Vector3f up =
      std::abs(toward.z()) < 0.9f ? Eigen::Vector3f::UnitZ() : Eigen::Vector3f::UnitY();
  frame.shadow_view_projection = orthographic(radius, radius, radius, 3 * radius) *
                                 look_at(frame.centre + toward * 2 * radius, frame.centre, up);
  frame.shadow_depth_range = 2 * radius;
  return frame;
}

}  // namespace psrig::preview
