#include "psrig/cloth/woven_bsdf.h"

#include <cmath>
#include <numbers>

namespace psrig::cloth {

namespace {
constexpr float kPi = std::numbers::pi_v<float>;
}

float microflake_distribution(const Eigen::Vector3f& h, const Eigen::Vector3f& orientation,
                              float alpha) {
  const float along = h.dot(orientation);
  const float q = h.squaredNorm() + (1 / (alpha * alpha) - 1) * along * along;
  return 1 / (kPi * alpha * q * q);
}

float microflake_projected_area(const Eigen::Vector3f& w, const Eigen::Vector3f& orientation,
                                float alpha) {
  const float along = w.dot(orientation);
  return std::sqrt(std::max(w.squaredNorm() + (alpha * alpha - 1) * along * along, 0.0f));
}

float woven_specular(const Eigen::Vector3f& wi, const Eigen::Vector3f& wo,
                     const Eigen::Vector3f& normal, const Eigen::Vector3f& orientation,
                     float alpha) {
  const float cos_i = wi.dot(normal), cos_o = wo.dot(normal);
  if (cos_i <= 0 || cos_o <= 0) return 0;
  const Eigen::Vector3f half = wi + wo;
  const float length = half.norm();
  if (length < 1e-6f) return 0;
  const float d = microflake_distribution(half / length, orientation, alpha);
  const float lambda = microflake_projected_area(wi, orientation, alpha) / cos_i +
                       microflake_projected_area(wo, orientation, alpha) / cos_o;
  const float g = -std::expm1(-kFabricDensityThickness * lambda) / lambda;
  return d * g / (4 * cos_i * cos_o);
}

float woven_diffuse(const Eigen::Vector3f& wi, const Eigen::Vector3f& wo,
                    const Eigen::Vector3f& normal, float diffuse_blend) {
  const float cos_i = wi.dot(normal), cos_o = wo.dot(normal);
  if (cos_i <= 0 || cos_o <= 0 || wi.z() <= 0) return 0;
  return (diffuse_blend * cos_i / wi.z() + (1 - diffuse_blend)) / kPi;
}

}  // namespace psrig::cloth
