#include "camera_matrices.h"

#include <cmath>
#include <numbers>

#include <Eigen/Geometry>

namespace psrig::preview {

float radians(double degrees) {
  return static_cast<float>(degrees * std::numbers::pi / 180.0);
}

Eigen::Matrix3f yaw_pitch(double yaw_deg, double pitch_deg) {
  return (Eigen::AngleAxisf(radians(yaw_deg), Eigen::Vector3f::UnitY()) *
          Eigen::AngleAxisf(radians(pitch_deg), Eigen::Vector3f::UnitX()))
      .toRotationMatrix();
}

Eigen::Matrix4f look_at(const Eigen::Vector3f& eye, const Eigen::Vector3f& target,
                        const Eigen::Vector3f& up) {
  const Eigen::Vector3f back = (eye - target).normalized();  // camera +z
  const Eigen::Vector3f right = up.cross(back).normalized();
  const Eigen::Vector3f true_up = back.cross(right);
  Eigen::Matrix4f m = Eigen::Matrix4f::Identity();
  m.block<1, 3>(0, 0) = right.transpose();
  m.block<1, 3>(1, 0) = true_up.transpose();
  m.block<1, 3>(2, 0) = back.transpose();
  m(0, 3) = -right.dot(eye);
  m(1, 3) = -true_up.dot(eye);
  m(2, 3) = -back.dot(eye);
  return m;
}

Eigen::Matrix4f perspective(float fov_y, float aspect, float near, float far) {
  const float f = 1 / std::tan(fov_y / 2);
  Eigen::Matrix4f m = Eigen::Matrix4f::Zero();
  m(0, 0) = f / aspect;
  m(1, 1) = f;
  m(2, 2) = (far + near) / (near - far);
  m(2, 3) = 2 * far * near / (near - far);
  m(3, 2) = -1;
  return m;
}

Eigen::Matrix4f orthographic(float half_width, float half_height, float near, float far) {
  Eigen::Matrix4f m = Eigen::Matrix4f::Zero();
  m(0, 0) = 1 / half_width;
  m(1, 1) = 1 / half_height;
  m(2, 2) = -2 / (far - near);
  m(2, 3) = -(far + near) / (far - near);
  m(3, 3) = 1;
  return m;
}

}  // namespace psrig::preview
