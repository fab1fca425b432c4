#pragma once
// The picture chen2024 6 compares against: a flat woven swatch, its pattern
// tiled without end, seen by a pinhole camera under one directional light,
// each pixel the fabric's BSDF aggregated over that pixel's footprint,
// estimated with `spp` samples (256 for the ground truth, 1 for the
// one-sample baseline) in one of two ways:
//
// - rays (the default): camera rays through the pixel traced to the yarns'
//   height field, each shaded where it lands. A ray meets a visible point
//   with probability in proportion to A(p, wo) of eq. (4), so the rays'
//   mean estimates eq. (3), and one ray is an honest one-sample render. A
//   ray can also meet the step where a yarn stands above its neighbour (the
//   rest of the yarn's side, which the model's flattened section leaves
//   out and eq. 3 has no point on); such a ray is drawn again (at most 4
//   spp draws a pixel), as eq. (3)'s A_P leaves the steps out. Shading the
//   steps with the yarn's edge instead made a twill's warps 13 % darker at
//   beta = 1 than eq. (3); drawn again, the two agree within 3 %
//   (woven_reference_render_test.cpp).
// - footprint: eq. (3) itself over the pixel's footprint on the mid-plane,
//   woven_aggregate.h's estimator with `spp` points: exactly what the data
//   set holds and a network learns. At one point a pixel it is biased (a
//   hidden point counts black), so the one-sample baseline is `rays`.
//
// Pixel = E (kd_warp c_warp + kd_weft c_weft + ks_warp s_warp + ks_weft
// s_weft), linear RGB, E the light's irradiance normal to it; 0 where a
// ray meets no cloth (above the horizon) or a gap.

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "psrig/cloth/woven_aggregate.h"
#include "psrig/cloth/woven_surface.h"

namespace psrig::cloth {

// k_d and k_s per yarn type, linear RGB.
struct YarnColours {
  Eigen::Vector3f warp_diffuse{0.8f, 0.8f, 0.8f}, weft_diffuse{0.8f, 0.8f, 0.8f};
  Eigen::Vector3f warp_specular{0.2f, 0.2f, 0.2f}, weft_specular{0.2f, 0.2f, 0.2f};
};

// Eq. (8): the four components weighted by the yarns' colours, an RGB BSDF
// value (times the light's irradiance, a pixel's radiance).
[[nodiscard]] Eigen::Vector3f woven_bsdf_colour(const WovenComponents& c, const YarnColours& colours);

// A pinhole camera looking at a point of the cloth's mid-plane (z = 0).
// Lengths in yarn spacings.
struct WovenView {
  float distance = 60;           // from the point looked at to the eye
  float tilt_deg = 30;           // the eye's angle from the cloth's normal
  float azimuth_deg = 0;         // about the normal, from +x (along the weft)
  float field_of_view_deg = 30;  // vertical
  Eigen::Vector2f target = Eigen::Vector2f::Zero();
};

struct WovenLight {
  Eigen::Vector3f direction{0, 0, 1};  // towards the light, unit, z > 0
  float irradiance = 1;
};

// Row-major, top row first, three floats a pixel (R, G, B), linear.
struct WovenImage {
  int width = 0, height = 0;
  std::vector<float> rgb;
  [[nodiscard]] Eigen::Vector3f at(int x, int y) const {
    const std::size_t i = (static_cast<std::size_t>(y) * width + x) * 3;
    return {rgb[i], rgb[i + 1], rgb[i + 2]};
  }
};

enum class WovenEstimator { rays, footprint };

// Runs on the thread pool, a row a task; the same image for the same seed on
// any number of threads.
[[nodiscard]] WovenImage render_woven_reference(const WovenSurface& surface,
                                                const WovenShading& shading,
                                                const YarnColours& colours, const WovenView& view,
                                                const WovenLight& light, int width, int height,
                                                int spp, std::uint64_t seed,
                                                WovenEstimator estimator = WovenEstimator::rays);

// The camera's geometry, for renderers that take the same view (the neural
// one): the eye, and where a point of the image, in pixels from the top
// left corner, meets the mid-plane (nothing above the horizon).
struct WovenCamera {
  Eigen::Vector3f eye, forward, right, up;
  float tan_half_fov = 0, aspect = 1;
  int width = 0, height = 0;
  [[nodiscard]] static WovenCamera look(const WovenView& view, int width, int height);
  [[nodiscard]] Eigen::Vector3f ray(float px, float py) const;  // unit
  [[nodiscard]] std::optional<Eigen::Vector2f> on_plane(float px, float py) const;
  // Pixel (x, y)'s footprint on the mid-plane: its centre and the plane's
  // steps of one pixel right and down.
  [[nodiscard]] std::optional<Footprint> pixel_footprint(int x, int y) const;
};

// The same picture through a camera placed by the caller (the preview's
// far view, whose camera is not a WovenView's: tests compare the two).
[[nodiscard]] WovenImage render_woven_reference(const WovenSurface& surface,
                                                const WovenShading& shading,
                                                const YarnColours& colours,
                                                const WovenCamera& camera, const WovenLight& light,
                                                int spp, std::uint64_t seed,
                                                WovenEstimator estimator = WovenEstimator::rays);

}  // namespace psrig::cloth
