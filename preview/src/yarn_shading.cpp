#include "psrig/preview/yarn_shading.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

namespace psrig::preview {
namespace {

constexpr float kTwoPi = 2 * std::numbers::pi_v<float>;
// The mean of ((1 - cos x) / 2)^4 over a turn: the groove profile's average.
constexpr float kMeanGroove = 35.0f / 128.0f;

// Integer hash (Wellons' lowbias32): the same bits in GLSL ES 3.00's uint.
std::uint32_t hash(std::uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

float signed_noise(std::uint32_t lattice) {
  return static_cast<float>(hash(lattice) >> 8) / 16777215.0f * 2 - 1;
}

float fract(float x) {
  return x - std::floor(x);
}

float smoothstep01(float x) {
  x = std::clamp(x, 0.0f, 1.0f);
  return x * x * (3 - 2 * x);
}

// Kajiya-Kay specular on a tangent shifted along the normal (the
// Marschner lobes' longitudinal shifts, as hair shaders place them).
float shifted_lobe(const Eigen::Vector3f& tangent, const Eigen::Vector3f& normal, float shift,
                   float exponent, const Eigen::Vector3f& half_vector) {
  const float along = (tangent + shift * normal).normalized().dot(half_vector);
  return std::pow(std::max(1 - along * along, 0.0f), exponent / 2);
}

}  // namespace

Eigen::Vector3f tube_normal(const Eigen::Vector3f& yarn_tangent, const Eigen::Vector3f& to_eye,
                            float across) {
  Eigen::Vector3f facing = to_eye - to_eye.dot(yarn_tangent) * yarn_tangent;
  if (facing.squaredNorm() < 1e-12f)  // looking down the yarn: any side will do
    facing = yarn_tangent.cross(std::abs(yarn_tangent.x()) < 0.9f ? Eigen::Vector3f::UnitX()
                                                                  : Eigen::Vector3f::UnitY());
  facing.normalize();
  const Eigen::Vector3f side = yarn_tangent.cross(facing);
  across = std::clamp(across, -1.0f, 1.0f);
  return across * side + std::sqrt(1 - across * across) * facing;
}

float ply_helix_angle(const cloth::YarnStyle& style) {
  if (style.twist_pitch_mm <= 0) return 0;
  return std::atan(std::numbers::pi_v<float> * style.radius_mm / style.twist_pitch_mm);
}

Eigen::Vector3f fibre_tangent(const Eigen::Vector3f& yarn_tangent, const Eigen::Vector3f& normal,
                              float helix_angle) {
  return std::cos(helix_angle) * yarn_tangent + std::sin(helix_angle) * normal.cross(yarn_tangent);
}

float crossing_light(float lift, const FibreShading& shading) {
  return 1 - shading.crossing_occlusion * (1 - std::min(std::abs(lift), 1.0f));
}

float fibre_detail(float around, float arc_mm, const cloth::YarnStyle& style, const FibreShading& shading,
                   float fibres_per_pixel) {
  const int plies = std::max(style.plies, 1);
  const int fibres_per_ply = std::max(shading.fibres_per_ply, 1);
  // Turns of the ply helix: constant along each ply as it winds round.
  const float turns =
      fract(around / kTwoPi - (style.twist_pitch_mm > 0 ? arc_mm / style.twist_pitch_mm : 0.0f));
  const float between = 0.5f - 0.5f * std::cos(kTwoPi * static_cast<float>(plies) * turns);
  const float plies_per_pixel = fibres_per_pixel / static_cast<float>(fibres_per_ply);
  const float ply_fade = std::clamp(2 - 2 * plies_per_pixel, 0.0f, 1.0f);
  const float squared = between * between;
  const float groove = kMeanGroove + (squared * squared - kMeanGroove) * ply_fade;
  const int stripes = plies * fibres_per_ply;
  const float stripe = turns * static_cast<float>(stripes);
  const float lattice = std::floor(stripe);
  const int below = static_cast<int>(lattice) % stripes;
  const float noise = signed_noise(static_cast<std::uint32_t>(below)) +
                      (signed_noise(static_cast<std::uint32_t>((below + 1) % stripes)) -
                       signed_noise(static_cast<std::uint32_t>(below))) *
                          smoothstep01(stripe - lattice);
  const float fibre_fade = std::clamp(2 - 2 * fibres_per_pixel, 0.0f, 1.0f);
  return (1 - shading.ply_groove * groove) * (1 + shading.striation * noise * fibre_fade);
}

float mean_fibre_detail(const FibreShading& shading) {
  return 1 - shading.ply_groove * kMeanGroove;
}

Eigen::Vector3f shade_fibres(const FibrePoint& point, const Eigen::Vector3f& to_light,
                             const Eigen::Vector3f& to_eye, float attenuation, float shadow,
                             const FibreShading& shading) {
  const Eigen::Vector3f light = to_light.normalized();
  const Eigen::Vector3f eye = to_eye.normalized();
  const Eigen::Vector3f& tangent = point.fibre_tangent;
  const float facing =
      std::clamp((point.normal.dot(light) + shading.wrap) / (1 + shading.wrap), 0.0f, 1.0f);
  const float along_light = tangent.dot(light);
  const float kajiya_kay = std::sqrt(std::max(1 - along_light * along_light, 0.0f));
  const Eigen::Vector3f half_vector = (light + eye).normalized();
  const float primary = shifted_lobe(tangent, point.normal, shading.primary_shift,
                                     shading.primary_exponent, half_vector);
  const float secondary = shifted_lobe(tangent, point.normal, shading.secondary_shift,
                                       shading.secondary_exponent, half_vector);
  const float direct = attenuation * shadow * facing;
  Eigen::Vector3f colour;
  for (int c = 0; c < 3; ++c) {
    const float albedo = point.colour[c];
    const float lit = albedo * shading.diffuse * kajiya_kay + shading.primary_specular * primary +
                      albedo * shading.secondary_specular * secondary;
    colour[c] =
        point.light_scale * (albedo * shading.ambient + shading.light_colour[c] * direct * lit);
  }
  return colour;
}

}  // namespace psrig::preview
