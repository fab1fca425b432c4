#pragma once
// Where everything is in one frame: the swatch's patch (model), the camera
// and the light, each turned on its own (VirTex let the user rotate model,
// camera and light independently). World axes are the scan's (docs/design.md "Axes and units"):
// x right, y up, z toward the camera; with no rotation the swatch lies in
// the x-y plane as it lay under the rig, and a light of tilt 0 comes from
// +x. Units are the swatch's: millimetres, or pixels when unknown.

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "psrig/cloth/bezier_patch.h"

namespace psrig::preview {

// flat: the swatch head-on and orthographic, filling the frame (the view
// golden tests compare); patch: a draped sheet in perspective.
enum class ViewKind { flat, patch };
enum class LightKind { directional, point };

struct LightSetup {
  LightKind kind = LightKind::directional;
  double tilt_deg = 0;    // in the swatch plane from +x toward +y
  double slant_deg = 45;  // from +z
  // Point light: its distance from the patch centre, in patch diagonals.
  double distance = 0.75;
};

struct SceneView {
  ViewKind kind = ViewKind::flat;
  double model_yaw_deg = 0;  // about y, then pitch about x
  double model_pitch_deg = 0;
  double camera_yaw_deg = 0;  // the camera orbits the patch centre
  double camera_pitch_deg = 0;
  double zoom = 1;
  LightSetup light;
  bool show_light = true;  // the light drawn as a small sphere
  double margin = 0;       // flat: frame border, a fraction of the swatch
};

// The draped sheet is this many swatches wide and high (the maps tile).
inline constexpr int kDrapedTiles = 2;

struct FrameSetup {
  cloth::PatchShape shape = cloth::PatchShape::flat;
  cv::Size2d patch_extent;  // the patch's size in the x-y plane
  Eigen::Matrix4f model, view, projection;
  // World space. eye: the camera position (w = 1) or, orthographic, the
  // direction toward it (w = 0). light: position (w = 1) or direction
  // toward the light (w = 0).
  Eigen::Vector4f eye, light;
  float light_reference_distance = 1;  // a point light is at full strength this far away
  Eigen::Vector3f marker_centre;       // where the light's sphere is drawn
  float marker_radius = 1;
};

// `swatch_extent` is the maps' physical size (SwatchMaps::extent()).
[[nodiscard]] FrameSetup frame_setup(cv::Size2d swatch_extent, const SceneView& view,
                                     cv::Size viewport);

}  // namespace psrig::preview
