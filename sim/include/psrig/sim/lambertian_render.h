#pragma once
// Image formation for the simulated world: a Lambertian swatch under one
// distant light, with cast shadows from the height field.

#include <opencv2/core.hpp>

#include "psrig/sim/swatch_model.h"

namespace psrig::sim {

struct DistantLight {
  cv::Vec3d direction{0, 0, 1};  // from the swatch toward the light, camera axes; need not be unit
  cv::Vec3f intensity_bgr{1, 1, 1};  // irradiance at normal incidence, per channel (BGR)
};

// Linear radiance, CV_32FC3 (BGR): albedo * intensity * max(0, n . l), and 0
// where the height field blocks the light (when cast_shadows is set).
[[nodiscard]] cv::Mat render_lambertian(const Swatch& swatch, const DistantLight& light,
                                        bool cast_shadows = true);

// A near LED: a point source at a position in millimetres, camera axes, origin
// where the camera axis (the image centre) meets the swatch plane.
struct PointLight {
  cv::Vec3d position_mm{0, 0, 250};
  cv::Vec3f intensity_bgr{1, 1, 1};  // irradiance at normal incidence at the origin, per channel
};

// Linear radiance, CV_32FC3 (BGR), under a point source: each pixel's
// swatch point X = ((col - (w-1)/2) s, ((h-1)/2 - row) s, height - mean
// height), s the swatch's pixel size, sees the light from (P - X)/|P - X|
// with irradiance scaled by |P|²/|P - X|² (1/r², equal to the intensity at
// the origin): albedo * intensity * |P|² * max(0, n . (P - X)) / |P - X|³.
// Cast shadows, when set, are marched toward the light as seen from the
// field's centre (the direction changes by well under a degree over a yarn's
// shadow).
[[nodiscard]] cv::Mat render_point_light(const Swatch& swatch, const PointLight& light,
                                         bool cast_shadows = true);

// CV_8U, 255 where the height field blocks the light from that pixel: a ray
// marched toward the light in half-pixel steps over the bilinear height
// meets higher ground before it rises above the field or leaves the image.
// An overhead light casts no shadow; one at or below the swatch's plane
// (direction z <= 0) is blocked everywhere.
[[nodiscard]] cv::Mat cast_shadow_mask(const cv::Mat& height_mm, double pixel_size_mm,
                                       const cv::Vec3d& direction);

}  // namespace psrig::sim
