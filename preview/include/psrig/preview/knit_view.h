#pragma once
// Where the camera and the light are when yarns are drawn: the camera
// orbits the fabric's bounds centre in perspective, the light is placed as
// for the swatch (scene_view.h's LightSetup, relative to the fabric's axes),
// and the shadow map looks along the light, orthographic, fitted to the
// bounds. Pure maths, so tests can project points as the renderer does.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "psrig/preview/scene_view.h"

namespace psrig::preview {

struct KnitView {
  double yaw_deg = 0;      // camera orbit about y, then pitch about x (as SceneView's camera)
  double pitch_deg = 0;    // positive: looking down onto the fabric from above
  double distance_mm = 0;  // camera to bounds centre; 0: the whole fabric fits the frame
  double fov_y_deg = 30;
  // A point light's `distance` is in bounds diagonals from the bounds centre.
  LightSetup light;
  cv::Vec3f background{0.02f, 0.02f, 0.025f};  // linear
  bool shadows = true;                         // yarns shadow yarns (a shadow map from the light)
  bool fibre_detail = true;                    // ply grooves and fibre striation
};

struct KnitFrame {
  Eigen::Matrix4f view, projection;
  Eigen::Vector3f centre;  // the bounds centre the camera orbits
  Eigen::Vector3f eye;     // the camera's position
  float distance = 1;      // eye to centre
  float focal_px = 1;      // pixels per millimetre at unit distance
  // Orthographic (the far level's bakes, repeat_texture.h): clip w is 1, and
  // every point is `distance` from the eye as far as yarn widths go.
  bool orthographic = false;
  // Position (w = 1) or direction toward the light (w = 0).
  Eigen::Vector4f light;
  float light_reference_distance = 1;  // a point light is at full strength this far away
  // Added to every yarn's own phase along its slice (0 to 1, a period): the
  // far level's bakes average over it (repeat_texture.h).
  float slice_phase = 0;
  // Shadow map: the light's view and orthographic projection, depth in
  // [-1, 1] spanning `shadow_depth_range` millimetres.
  Eigen::Matrix4f shadow_view_projection;
  Eigen::Vector3f toward_shadow_light;  // unit, the direction the shadow map looks back along
  float shadow_depth_range = 1;

  // Pixel coordinates (x right, y down, pixel centres at .5) of a point.
  [[nodiscard]] Eigen::Vector2f project(const Eigen::Vector3f& point, cv::Size viewport) const;
};

[[nodiscard]] KnitFrame knit_frame(const Eigen::AlignedBox3f& bounds, const KnitView& view,
                                   cv::Size viewport);

}  // namespace psrig::preview
