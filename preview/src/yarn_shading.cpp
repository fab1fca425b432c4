#include "psrig/preview/yarn_shading.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Geometry>

namespace psrig::preview {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;

// Any unit vector normal to unit `v` (for degenerate views).
Eigen::Vector3f normal_to(const Eigen::Vector3f& v) {
  return v.cross(std::abs(v.x()) < 0.9f ? Eigen::Vector3f::UnitX() : Eigen::Vector3f::UnitY())
      .normalized();
}

// `v` without its component along unit `t`, unit; `fallback` where nothing is left.
Eigen::Vector3f across_of(const Eigen::Vector3f& v, const Eigen::Vector3f& t,
                          const Eigen::Vector3f& fallback) {
  const Eigen::Vector3f rest = v - v.dot(t) * t;
  return rest.squaredNorm() > 1e-12f * std::max(v.squaredNorm(), 1e-30f) ? rest.normalized()
                                                                        : fallback;
}

float clamped_flatness(float flatness) {
  return std::clamp(flatness, 0.05f, 1.0f);
}

Eigen::Vector3f max_zero(const Eigen::Vector3f& v) {
  return v.cwiseMax(0.0f);
}

// The longitudinal Gaussian of a lobe in the half angle's sine.
float lobe(float half, float shift, float width) {
  const float d = half - shift;
  return std::exp(-d * d / (2 * width * width));
}

}  // namespace

StripFrame strip_frame(const Eigen::Vector3f& tangent, const Eigen::Vector3f& cloth_normal,
                       const Eigen::Vector3f& to_eye, float radius_mm, float flatness) {
  StripFrame frame;
  const Eigen::Vector3f t = tangent.normalized();
  frame.tangent = t;
  frame.facing = across_of(to_eye, t, normal_to(t));
  frame.side = t.cross(frame.facing);
  // The cross-section's axes: `up` along the cloth's normal, `in_plane` across.
  const Eigen::Vector3f up = across_of(cloth_normal, t, frame.facing);
  const Eigen::Vector3f in_plane = t.cross(up);
  const float flat = clamped_flatness(flatness);
  const float view_in = frame.facing.dot(in_plane), view_up = frame.facing.dot(up);
  frame.half_width_mm =
      radius_mm * std::sqrt(view_up * view_up + flat * flat * view_in * view_in);
  // In the space where the ellipse is the unit circle (divide by its axes)
  // the strip coordinate is still the fraction of the silhouette's width:
  // the point seen there is a*side' + sqrt(1 - a^2)*facing', and the
  // ellipse's normal the circle's divided by the axes once more.
  Eigen::Vector2f facing_circle(view_in, view_up / flat);
  facing_circle.normalize();
  const Eigen::Vector2f side_circle(facing_circle.y(), -facing_circle.x());
  frame.across_normal = side_circle.x() * in_plane + side_circle.y() / flat * up;
  frame.facing_normal = facing_circle.x() * in_plane + facing_circle.y() / flat * up;
  frame.turn = (kPi / 2 - std::atan2(view_up, view_in)) / (2 * kPi);
  return frame;
}

Eigen::Vector3f strip_normal(const StripFrame& frame, float across) {
  const float a = std::clamp(across, -1.0f, 1.0f);
  return (a * frame.across_normal + std::sqrt(std::max(1 - a * a, 0.0f)) * frame.facing_normal)
      .normalized();
}

Eigen::Vector3f toward_light_surface(const Eigen::Vector3f& tangent,
                                     const Eigen::Vector3f& cloth_normal,
                                     const Eigen::Vector3f& to_light, float radius_mm,
                                     float flatness) {
  const Eigen::Vector3f t = tangent.normalized();
  const Eigen::Vector3f l = to_light.normalized();
  const Eigen::Vector3f up = across_of(cloth_normal, t, normal_to(t));
  const Eigen::Vector3f in_plane = t.cross(up);
  const float a = radius_mm, b = clamped_flatness(flatness) * radius_mm;
  const float l_in = l.dot(in_plane), l_up = l.dot(up);
  const float reach = std::sqrt(a * a * l_in * l_in + b * b * l_up * l_up);
  if (reach < 1e-9f) return Eigen::Vector3f::Zero();
  return (a * a * l_in * in_plane + b * b * l_up * up) / reach;
}

float ply_helix_angle(const cloth::YarnStyle& style) {
  if (style.twist_pitch_mm <= 0) return 0;
  return std::atan(kPi * style.radius_mm / style.twist_pitch_mm);
}

float crossing_light(float lift, const FibreShading& shading) {
  return 1 - shading.crossing_occlusion * (1 - std::min(std::abs(lift), 1.0f));
}

float statistical_shadow(float lift, const Eigen::Vector3f& cloth_normal,
                         const Eigen::Vector3f& to_light, const FibreShading& shading) {
  const float c = cloth_normal.normalized().dot(to_light.normalized());
  const float on_top = std::clamp(c >= 0 ? lift : -lift, -1.0f, 1.0f);
  const float depth = (1 - on_top) / 2;
  const float tangent = std::sqrt(std::max(1 - c * c, 0.0f)) / std::max(std::abs(c), 0.05f);
  return std::exp(-shading.shadow_density * depth * tangent);
}

Eigen::Vector3f local_scattering_gain(const Eigen::Vector3f& albedo, const FibreShading& shading) {
  const Eigen::Vector3f bounce = shading.local_scattering * albedo.cwiseMin(0.98f);
  return Eigen::Vector3f::Ones() + bounce.cwiseQuotient(Eigen::Vector3f::Ones() - bounce);
}

Eigen::Vector3f transmitted_shadow(float shadow, const Eigen::Vector3f& albedo,
                                   const FibreShading& shading) {
  return Eigen::Vector3f::Constant(shadow) + (1 - shadow) * shading.global_scattering * albedo;
}

Eigen::Vector3f environment_shading(const EnvironmentLight& environment,
                                    const Eigen::Vector3f& normal, const Eigen::Vector3f& tangent,
                                    const Eigen::Vector3f& to_eye, const Eigen::Vector3f& albedo,
                                    const FibreShading& shading) {
  const Eigen::Vector3f diffuse =
      (1 - shading.environment_fibre) * max_zero(environment.lambert(normal)) +
      shading.environment_fibre * max_zero(environment.fibre(tangent));
  const Eigen::Vector3f eye = to_eye.normalized();
  const Eigen::Vector3f mirror = 2 * normal.dot(eye) * normal - eye;
  const Eigen::Vector3f sheen = max_zero(environment.radiance(mirror));
  return shading.environment *
         (albedo.cwiseProduct(local_scattering_gain(albedo, shading)).cwiseProduct(diffuse) +
          shading.environment_sheen * sheen);
}

VertexShading vertex_shading(const StripFrame& frame, const Eigen::Vector3f& albedo, float lift,
                             const Eigen::Vector3f& to_eye, float attenuation, float shadow,
                             const EnvironmentLight& environment, const FibreShading& shading) {
  VertexShading vertex;
  const float crossing = crossing_light(lift, shading);
  for (int i = 0; i < 3; ++i)
    vertex.environment[i] =
        crossing * environment_shading(environment, strip_normal(frame, static_cast<float>(i - 1)),
                                       frame.tangent, to_eye, albedo, shading);
  vertex.direct = (attenuation * crossing) *
                  shading.light_colour.cwiseProduct(transmitted_shadow(shadow, albedo, shading));
  vertex.albedo = albedo;
  return vertex;
}

Eigen::Vector3f environment_across(const VertexShading& vertex, float across) {
  const float a = std::clamp(across, -1.0f, 1.0f);
  const Eigen::Vector3f& left = vertex.environment[0];
  const Eigen::Vector3f& middle = vertex.environment[1];
  const Eigen::Vector3f& right = vertex.environment[2];
  return middle + (0.5f * a) * (right - left) + (a * a) * (0.5f * (right + left) - middle);
}

FibreSurface plain_surface(const cloth::YarnStyle& style) {
  return {0, std::sin(ply_helix_angle(style)), 1};
}

FibreSurface slice_surface(const SliceSample& sample) {
  return {sample.ply_offset, sample.tilt_sin, sample.light};
}

float prefiltered_coverage(float distance_px, float half_px, float filter_px) {
  const auto tent_integral = [](float y) {
    y = std::clamp(y, -1.0f, 1.0f);
    return y < 0 ? 0.5f * (1 + y) * (1 + y) : 1 - 0.5f * (1 - y) * (1 - y);
  };
  const float d = std::abs(distance_px), f = std::max(filter_px, 1e-3f);
  return tent_integral((d + half_px) / f) - tent_integral((d - half_px) / f);
}

Eigen::Vector3f ply_across_direction(const StripFrame& frame, float ply_slant_sin) {
  const float cosine = std::sqrt(std::max(1 - ply_slant_sin * ply_slant_sin, 0.0f));
  return cosine * frame.side - ply_slant_sin * frame.tangent;
}

Eigen::Vector3f shade_fragment(const StripFrame& frame, float across, const FibreSurface& surface,
                               const Eigen::Vector3f& ply_across, const VertexShading& vertex,
                               const Eigen::Vector3f& to_light, const Eigen::Vector3f& to_eye,
                               const FibreShading& shading) {
  const Eigen::Vector3f& tangent = frame.tangent;
  const Eigen::Vector3f normal =
      (strip_normal(frame, across) + shading.ply_relief * surface.ply_offset * ply_across)
          .normalized();
  const float tilt_cos = std::sqrt(std::max(1 - surface.tilt_sin * surface.tilt_sin, 0.0f));
  const Eigen::Vector3f fibre =
      (tilt_cos * tangent + surface.tilt_sin * normal.cross(tangent)).normalized();
  const Eigen::Vector3f light = to_light.normalized();
  const Eigen::Vector3f eye = to_eye.normalized();
  const float sin_in = fibre.dot(light), sin_out = fibre.dot(eye);
  const float kajiya_kay = std::sqrt(std::max(1 - sin_in * sin_in, 0.0f));
  const float half = 0.5f * (sin_in + sin_out);
  const float reflection = lobe(half, shading.r_shift, shading.r_width);
  const float transmission = lobe(half, shading.tt_shift, shading.tt_width);
  // Azimuth between light and eye about the fibre: R faces back, TT through.
  const Eigen::Vector3f light_round = light - sin_in * fibre, eye_round = eye - sin_out * fibre;
  const float cos_azimuth =
      light_round.dot(eye_round) /
      std::sqrt(std::max(light_round.squaredNorm() * eye_round.squaredNorm(), 1e-8f));
  const float toward = 0.5f + 0.5f * cos_azimuth;
  float through = 0.5f - 0.5f * cos_azimuth;
  through *= through;
  through *= through;
  const float normal_light = normal.dot(light);
  const Eigen::Vector3f gain = local_scattering_gain(vertex.albedo, shading);
  // R off the fibres' surface sees the plain terminator; D, scattered
  // inside, wraps further round the lighter the yarn (the global part).
  const float surface_facing =
      std::clamp((normal_light + shading.wrap) / (1 + shading.wrap), 0.0f, 1.0f);
  Eigen::Vector3f direct;
  for (int c = 0; c < 3; ++c) {
    const float albedo = vertex.albedo[c];
    const float wrap = shading.wrap + (1 - shading.wrap) * shading.global_scattering * albedo;
    const float facing = std::clamp((normal_light + wrap) / (1 + wrap), 0.0f, 1.0f);
    direct[c] = facing * albedo * gain[c] * shading.diffuse * kajiya_kay +
                surface_facing * shading.r_weight * reflection * toward +
                albedo * shading.tt_weight * transmission * through;
  }
  return surface.light * (environment_across(vertex, across) + vertex.direct.cwiseProduct(direct));
}

}  // namespace psrig::preview
