#include "psrig/cloth/woven_reference_render.h"

#include <cmath>
#include <numbers>

#include <Eigen/Geometry>

#include "psrig/base/parallel.h"

namespace psrig::cloth {

namespace {

constexpr float kRenderDegree = std::numbers::pi_v<float> / 180;

// How far below the height field a ray's landing may be and still be on
// it: deeper, it met the step at a yarn's side.
constexpr float kStepDepth = 1e-3f;

// One camera ray's radiance over E where it lands, or nothing where it
// meets a yarn's side step (eq. 3 has no such point: the ray is drawn
// again, so that the rays land as eq. 3's A(p, wo) weighs the points).
std::optional<Eigen::Vector3f> trace_pixel_ray(
    const WovenSurface& surface, const WovenShading& shading, const YarnColours& colours,
    const Eigen::Vector3f& eye, const Eigen::Vector3f& direction, const Eigen::Vector3f& wi) {
  const std::optional<Eigen::Vector3f> hit = surface.first_hit(eye, direction);
  if (!hit) return Eigen::Vector3f::Zero();
  const WovenPoint p = surface.point(hit->head<2>());
  if (hit->z() < p.height - kStepDepth) return std::nullopt;
  if (p.yarn == YarnType::gap) return Eigen::Vector3f::Zero();
  const float lit = wi.dot(p.normal);
  if (lit <= 0 || !surface.visible(*hit, wi)) return Eigen::Vector3f::Zero();
  const Eigen::Vector3f wo = -direction;
  const bool warp = p.yarn == YarnType::warp;
  const float diffuse = woven_diffuse(wi, wo, p.normal, shading.diffuse_blend);
  const float specular = woven_specular(wi, wo, p.normal, p.orientation,
                                        warp ? shading.warp_alpha : shading.weft_alpha);
  const Eigen::Vector3f& kd = warp ? colours.warp_diffuse : colours.weft_diffuse;
  const Eigen::Vector3f& ks = warp ? colours.warp_specular : colours.weft_specular;
  return lit * (diffuse * kd + specular * ks);
}

}  // namespace

WovenCamera WovenCamera::look(const WovenView& view, int width, int height) {
  WovenCamera camera;
  const float tilt = view.tilt_deg * kRenderDegree, azimuth = view.azimuth_deg * kRenderDegree;
  const Eigen::Vector3f target(view.target.x(), view.target.y(), 0);
  const Eigen::Vector3f towards_eye(std::sin(tilt) * std::cos(azimuth),
                                    std::sin(tilt) * std::sin(azimuth), std::cos(tilt));
  camera.eye = target + view.distance * towards_eye;
  camera.forward = -towards_eye;
  // Right stays in the cloth's plane, continuous down to a head-on view.
  camera.right = Eigen::Vector3f(-std::sin(azimuth), std::cos(azimuth), 0);
  camera.up = camera.right.cross(camera.forward);
  camera.tan_half_fov = std::tan(view.field_of_view_deg * kRenderDegree / 2);
  camera.aspect = static_cast<float>(width) / static_cast<float>(height);
  camera.width = width;
  camera.height = height;
  return camera;
}

Eigen::Vector3f WovenCamera::ray(float px, float py) const {
  const float sx = (2 * px / static_cast<float>(width) - 1) * tan_half_fov * aspect;
  const float sy = (1 - 2 * py / static_cast<float>(height)) * tan_half_fov;
  return (forward + sx * right + sy * up).normalized();
}

std::optional<Eigen::Vector2f> WovenCamera::on_plane(float px, float py) const {
  const Eigen::Vector3f d = ray(px, py);
  if (d.z() >= -1e-6f) return std::nullopt;
  const float t = -eye.z() / d.z();
  return (eye + t * d).head<2>();
}

std::optional<Footprint> WovenCamera::pixel_footprint(int x, int y) const {
  const float cx = static_cast<float>(x) + 0.5f, cy = static_cast<float>(y) + 0.5f;
  const auto centre = on_plane(cx, cy);
  const auto left = on_plane(cx - 0.5f, cy), right_edge = on_plane(cx + 0.5f, cy);
  const auto top = on_plane(cx, cy - 0.5f), bottom = on_plane(cx, cy + 0.5f);
  if (!centre || !left || !right_edge || !top || !bottom) return std::nullopt;
  return Footprint{*centre, *right_edge - *left, *bottom - *top};
}

Eigen::Vector3f woven_bsdf_colour(const WovenComponents& c, const YarnColours& colours) {
  return c.c_warp * colours.warp_diffuse + c.c_weft * colours.weft_diffuse +
         c.s_warp * colours.warp_specular + c.s_weft * colours.weft_specular;
}

WovenImage render_woven_reference(const WovenSurface& surface, const WovenShading& shading,
                                  const YarnColours& colours, const WovenView& view,
                                  const WovenLight& light, int width, int height, int spp,
                                  std::uint64_t seed, WovenEstimator estimator) {
  if (width <= 0 || height <= 0) return {};
  return render_woven_reference(surface, shading, colours, WovenCamera::look(view, width, height),
                                light, spp, seed, estimator);
}

WovenImage render_woven_reference(const WovenSurface& surface, const WovenShading& shading,
                                  const YarnColours& colours, const WovenCamera& camera,
                                  const WovenLight& light, int spp, std::uint64_t seed,
                                  WovenEstimator estimator) {
  WovenImage image;
  const int width = camera.width, height = camera.height;
  if (width <= 0 || height <= 0 || spp <= 0) return image;
  image.width = width;
  image.height = height;
  image.rgb.assign(static_cast<std::size_t>(width) * height * 3, 0);
  const Eigen::Vector3f wi = light.direction.normalized();
  parallel_chunks(height, 1, [&](int begin, int end) {
    for (int y = begin; y < end; ++y)
      for (int x = 0; x < width; ++x) {
        const std::uint64_t pixel = static_cast<std::uint64_t>(y) * width + x;
        const std::size_t i = static_cast<std::size_t>(pixel) * 3;
        if (estimator == WovenEstimator::footprint) {
          const std::optional<Footprint> footprint = camera.pixel_footprint(x, y);
          if (!footprint) continue;
          const Eigen::Vector3f wo = -camera.ray(x + 0.5f, y + 0.5f);
          const WovenComponents c = aggregate_woven_bsdf(surface, shading, *footprint, wi, wo, spp,
                                                         mix_seed(seed, pixel));
          const Eigen::Vector3f value =
              light.irradiance *
              woven_bsdf_colour(c, colours);
          image.rgb[i] = value.x();
          image.rgb[i + 1] = value.y();
          image.rgb[i + 2] = value.z();
          continue;
        }
        SampleRandom random(mix_seed(seed, pixel));
        // A randomly shifted R2 sequence over the pixel (as woven_aggregate).
        const double shift_a = random.uniform(), shift_b = random.uniform();
        Eigen::Vector3f sum = Eigen::Vector3f::Zero();
        // Rays that meet a side step are drawn again, the sequence going
        // on, at most 4 spp draws in all.
        int landed = 0;
        for (int k = 0; landed < spp && k < 4 * spp; ++k) {
          double a = shift_a + 0.7548776662466927 * k, b = shift_b + 0.5698402909980532 * k;
          a -= std::floor(a);
          b -= std::floor(b);
          const Eigen::Vector3f d =
              camera.ray(static_cast<float>(x + a), static_cast<float>(y + b));
          if (const auto radiance = trace_pixel_ray(surface, shading, colours, camera.eye, d, wi)) {
            sum += *radiance;
            ++landed;
          }
        }
        if (landed == 0) continue;
        const Eigen::Vector3f value = light.irradiance * sum / static_cast<float>(landed);
        image.rgb[i] = value.x();
        image.rgb[i + 1] = value.y();
        image.rgb[i + 2] = value.z();
      }
  });
  return image;
}

}  // namespace psrig::cloth
