#pragma once
// The camera matrices both views build (the swatch's scene view, the knit
// view): OpenGL conventions, camera looking down its -z.

#include <Eigen/Core>

namespace psrig::preview {

[[nodiscard]] float radians(double degrees);

// Yaw about y, then pitch about x, both in degrees.
[[nodiscard]] Eigen::Matrix3f yaw_pitch(double yaw_deg, double pitch_deg);

[[nodiscard]] Eigen::Matrix4f look_at(const Eigen::Vector3f& eye, const Eigen::Vector3f& target,
                                      const Eigen::Vector3f& up);
[[nodiscard]] Eigen::Matrix4f perspective(float fov_y, float aspect, float near, float far);
[[nodiscard]] Eigen::Matrix4f orthographic(float half_width, float half_height, float near,
                                           float far);

}  // namespace psrig::preview
