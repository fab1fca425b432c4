#pragma once
// Light from all around, for the yarn renderer: an environment map reduced
// to its spherical harmonics up to order 2 (nine RGB coefficients), which a
// shader evaluates in a few dozen multiply-adds. Two convolutions of it:
// the cosine lobe of a surface (Ramamoorthi and Hanrahan 2001: the
// irradiance a yarn's tube normal receives) and the Kajiya-Kay lobe of a
// fibre, sqrt(1 - (t.w)^2) about its tangent t (the light a fibre scatters
// whatever its azimuth), both exact for the order-2 environment by the
// Funk-Hecke theorem. Where the map comes from: a sum of Gaussian lobes
// (huang2025-realtime-knit-deformation-rendering.txt, 4.5, eq. 14: the
// spherical radial basis functions the paper fits to an environment map;
// `studio()` is one such sum) or an equirectangular image. Directions in
// the scan's axes (docs/design.md): +z toward the camera, +y up. Linear RGB
// radiance.

#include <array>
#include <filesystem>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "psrig/base/error.h"

namespace psrig::preview {

// One Gaussian lobe: W exp(lambda (w.axis - 1)).
struct RadialLobe {
  Eigen::Vector3f axis{0, 0, 1};  // unit
  float sharpness = 1;            // lambda; 0 is a uniform sky
  Eigen::Vector3f weight{1, 1, 1};
};

class EnvironmentLight {
 public:
  // No light from anywhere.
  EnvironmentLight() { sh_.fill(Eigen::Vector3f::Zero()); }

  // Projected onto the harmonics numerically (fine enough for any lobe up
  // to sharpness 64).
  [[nodiscard]] static EnvironmentLight from_lobes(const std::vector<RadialLobe>& lobes);
  // A photographer's studio at about the strength of the old flat ambient
  // term: a broad soft box above and in front, a cooler sky, a warm floor.
  [[nodiscard]] static EnvironmentLight studio();
  // Uniform radiance from everywhere (the old ambient term).
  [[nodiscard]] static EnvironmentLight uniform(const Eigen::Vector3f& radiance);
  // An equirectangular map (longitude across, from -x through +z to +x and
  // back; latitude down the rows, +y at the top): float (EXR, TIFF) or
  // 8/16-bit images, the latter sRGB encoded.
  [[nodiscard]] static EnvironmentLight from_equirectangular(const cv::Mat& image);
  [[nodiscard]] static Result<EnvironmentLight> load(const std::filesystem::path& file);

  // Radiance arriving from direction `w` as the order-2 harmonics give it.
  [[nodiscard]] Eigen::Vector3f radiance(const Eigen::Vector3f& w) const;
  // Cosine-weighted irradiance over the hemisphere about unit `normal`,
  // divided by pi: what a white Lambertian surface reflects.
  [[nodiscard]] Eigen::Vector3f lambert(const Eigen::Vector3f& normal) const;
  // Integral of radiance times sqrt(1 - (tangent.w)^2) over the sphere,
  // divided by pi^2: what a white Kajiya-Kay fibre along unit `tangent`
  // scatters (1 for a uniform radiance of 1).
  [[nodiscard]] Eigen::Vector3f fibre(const Eigen::Vector3f& tangent) const;

  // The nine coefficients (l = 0, then l = 1: y, z, x, then l = 2: xy, yz,
  // 3z^2 - 1, xz, x^2 - y^2), each RGB, as the shader's uniforms take them.
  [[nodiscard]] const std::array<Eigen::Vector3f, 9>& coefficients() const { return sh_; }

 private:
  // The harmonics at `w`, band l scaled by bands[l] (a zonal kernel's).
  [[nodiscard]] Eigen::Vector3f convolved(const Eigen::Vector3f& w,
                                          const std::array<float, 3>& bands) const;
  std::array<Eigen::Vector3f, 9> sh_;
};

// The real spherical harmonics up to order 2 at unit `w`, in coefficients()'s order.
[[nodiscard]] std::array<float, 9> harmonics(const Eigen::Vector3f& w);

}  // namespace psrig::preview
