#pragma once
// Light-calibration targets for the simulated world: a chrome or a matte
// sphere resting on black velvet, seen by the rig's orthographic camera.
//
// - chrome: a mirror (reflectance 0.6) over a faint diffuse layer (albedo
//   0.04, as real chrome balls show), so its silhouette stays visible; each
//   LED is a small disc of finite angular size whose radiance gives unit
//   irradiance at normal incidence, so its mirror image is a small, very
//   bright (saturated) highlight.
// - matte: Lambertian, albedo 0.5 (no saturation at the default LED
//   irradiance), attached shadows where n . l <= 0.
// The velvet (albedo 0.004) carries the sphere's cast shadow.
// Rendered with 4x4 samples per pixel, so edges are anti-aliased, then
// blurred by the lens (a Gaussian point spread of 0.6 pixels).

#include <vector>

#include <opencv2/core.hpp>

#include "psrig/sim/swatch_model.h"

namespace psrig::sim {

enum class SphereKind { chrome, matte };

struct SphereTarget {
  SphereKind kind = SphereKind::chrome;
  cv::Size size{640, 480};
  double pixel_size_mm = 0.025;
  double diameter_mm = 10;
  double led_angular_diameter_deg = 2;
  // The sphere's centre in pixel coordinates (x right, row down; pixel
  // centres at integers); default: the image centre.
  cv::Point2d centre{-1, -1};

  [[nodiscard]] cv::Point2d centre_px() const;
  [[nodiscard]] double radius_px() const { return diameter_mm / 2 / pixel_size_mm; }
};

// The scene's geometry as a Swatch: height (mm above the velvet), normals
// and albedo (the chrome's diffuse layer), for ground truth.
[[nodiscard]] Swatch sphere_scene(const SphereTarget& target);

// Linear radiance (CV_32FC3, BGR, relative to the LED's irradiance at
// normal incidence, as render_lambertian's) under a distant LED toward
// `direction`.
[[nodiscard]] cv::Mat render_sphere(const SphereTarget& target, const cv::Vec3d& direction);

// Under the room light (an overcast sky, as the swatch world's), same scale.
[[nodiscard]] cv::Mat render_sphere_ambient(const SphereTarget& target);

// The target under a near LED, a point source at `position_mm` (camera
// axes, origin where the camera axis, the image centre, meets the velvet):
// each sample sees the LED from its own point (on the sphere, or on the
// velvet), so the chrome highlight moves with the sphere's placement.
[[nodiscard]] cv::Mat render_sphere_point(const SphereTarget& target, const cv::Vec3d& position_mm);

}  // namespace psrig::sim
