#pragma once
// Light directions (and relative intensities) from images of a sphere:
// the highlight on a chrome sphere, or a Lambertian fit over a matte one.
// Axes as docs/design.md: x right, y up, z toward the camera; a direction
// points from the scene toward the light.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/calibration/sphere.h"

namespace psrig::calibration {

// One image of the sphere under one light, linear, CV_32F grey, 0..1 of
// full scale (what the camera saturates at is `saturation`).
struct Frame {
  cv::Mat image;
  std::filesystem::path file;  // where it came from, for messages
};

// The frames of one light: one or more (averaged).
struct LightFrames {
  std::vector<Frame> frames;
};

struct CameraModel {
  // Focal length in pixels: perspective view rays through the principal
  // point (the image centre); absent: orthographic, every view ray (0, 0, 1).
  std::optional<double> focal_px;
};

struct LightEstimate {
  cv::Vec3d direction{0, 0, 1};  // unit, from the scene toward the light
  double intensity = 1;          // relative: the brightest light is 1 (matte); 1 (chrome)
  double uncertainty_deg = 0;    // one standard deviation of the direction, estimated
  // Chrome: the highlight's size (its intensity-weighted RMS radius) as an
  // angle, and how far the frames' directions scatter (RMS, 0 for one frame).
  std::optional<double> highlight_spread_deg;
  std::optional<double> frames_spread_deg;
  std::optional<cv::Point2d> highlight_px;  // the mean highlight centroid
  int frames = 0;
  // Matte: RMS residual of the Lambertian fit, fraction of full scale, and pixels used.
  std::optional<double> residual;
  std::optional<int> pixels;
};

[[nodiscard]] double tilt_deg(const cv::Vec3d& direction);
[[nodiscard]] double slant_deg(const cv::Vec3d& direction);
[[nodiscard]] double angle_deg(const cv::Vec3d& a, const cv::Vec3d& b);

// The sphere's unit normal seen at pixel (x, y) (rows down), for a sphere
// imaged as `sphere`; nullopt off the sphere.
[[nodiscard]] std::optional<cv::Vec3d> sphere_normal(const Circle& sphere, cv::Point2d pixel,
                                                     const CameraModel& camera,
                                                     cv::Size image_size);
// The unit vector from the point seen at `pixel` toward the camera.
[[nodiscard]] cv::Vec3d view_direction(cv::Point2d pixel, const CameraModel& camera,
                                       cv::Size image_size);

// Chrome sphere: per light, per frame, the highlight (the saturated or
// brightest blob inside the sphere, its intensity-weighted centroid), the
// normal there, the view ray reflected about it; the frames' directions
// averaged. bad_input naming the frame when a light shows no highlight.
[[nodiscard]] Result<std::vector<LightEstimate>> calibrate_chrome(
    const std::vector<LightFrames>& lights, const Circle& sphere, const CameraModel& camera,
    double saturation = 0.98);

// Matte sphere: per light (frames averaged), least squares for
// b = albedo * intensity * direction over the sphere's lit pixels
// (I = n . b), leaving out shadowed, saturated and grazing pixels; the
// direction b / |b| and the intensity |b| relative to the brightest light.
[[nodiscard]] Result<std::vector<LightEstimate>> calibrate_matte(
    const std::vector<LightFrames>& lights, const Circle& sphere, const CameraModel& camera,
    double saturation = 0.98);

// --- Near-field LEDs: positions from the chrome sphere at several places.
//
// With the sphere at one place, each light's highlight gives a ray: from the
// highlight's point on the sphere, C + R n (C the sphere's centre in mm,
// R its radius, n the normal at the highlight), along the measured
// direction. The LED lies on every such ray; its position is the point
// nearest all of them in least squares, sum_i (I - d_i d_i^T) (P - o_i) = 0.

// One placement of the chrome sphere: its circle in the images and
// calibrate_chrome's estimates there (highlight_px and direction used).
struct SpherePlacement {
  Circle sphere;
  std::vector<LightEstimate> lights;
};

// What places pixels on the swatch plane: millimetres per pixel, the
// sphere's diameter, the image's size and where the camera axis meets it
// (absent: the image centre, ((w - 1)/2, (h - 1)/2)). Orthographic camera.
struct PlaneGeometry {
  double pixel_size_mm = 0;
  double sphere_diameter_mm = 0;  // 0: from each circle's radius
  cv::Size image_size;
  std::optional<cv::Point2d> principal_point_px;
};

struct LedPosition {
  cv::Vec3d position_mm{0, 0, 0};  // camera axes, origin where the axis meets the swatch plane
  double ray_rms_mm = 0;           // RMS distance of the rays from it
  double baseline_mm = 0;          // largest distance between the rays' origins
  // One standard deviation along its worst axis (mostly the distance, when
  // the baseline is short): the least-squares covariance from the rays'
  // scatter about the point (floored by the spheres' fits).
  double uncertainty_mm = 0;
};

// Each light's position from two or more placements (every placement with
// an estimate for every light). bad_input when there are too few
// placements, no pixel size, or rays too nearly parallel to cross (the
// placements too close together for the distance).
[[nodiscard]] Result<std::vector<LedPosition>> triangulate_leds(
    const std::vector<SpherePlacement>& placements, const PlaneGeometry& geometry);

}  // namespace psrig::calibration
