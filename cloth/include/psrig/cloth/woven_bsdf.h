#pragma once
// The fabric shading model at one point of a ply (chen2024 eq. 1 and 2,
// Jin et al. 2022's model with SpongeCake's fibre-like microflakes, Wang et
// al. 2022):
//
//   f = f_s + f_d
//   f_s = k_s D(h) G(wi, wo) / (4 cos wi cos wo)
//   f_d = w k_d <wi . n_p> / (pi <wi . n_s>) + (1 - w) k_d / pi
//   D(h) = 1 / (pi alpha q^2),   q = h^T S^-1 h
//   G = (1 - exp(-T rho (L(wi) + L(wo)))) / (L(wi) + L(wo)),   T rho = 2
//   L(w) = sigma(w) / cos w,     sigma(w) = sqrt(w^T S w)
//
// with S = R^T diag(1, 1, alpha^2) R, the microflake's axis along the ply:
// S = I + (alpha^2 - 1) t_p t_p^T, so q = 1 + (1/alpha^2 - 1) (h . t_p)^2
// and sigma(w)^2 = 1 + (alpha^2 - 1) (w . t_p)^2 for unit h and w. The
// cosines of f_s and L are taken about the ply normal n_p (SpongeCake's
// layer is the ply), n_s = +z is the cloth's. Reflection only: f = 0 when
// either direction is behind the ply (<w . n_p> <= 0). chen2024 does not give
// w; ours is 0.5 (WovenShading::diffuse_blend).
//
// Energy (woven_bsdf_test.cpp measures it): f_s with k_s = 1 is a slab's
// single scattering and reflects at most about half of what it receives
// (0.48 found, alpha = 0.1, light 89 degrees from the normal, across the
// ply; towards grazing it tends to the share of the microflakes' phase
// function sent upwards, below 1). f_d with k_d = 1 reflects w <wi . n_p> / <wi . n_s> + (1 - w)
// about n_p: exactly 1 where the ply lies flat, more where it leans towards a grazing light (w =
// 0.5, ply at 45 degrees, light at 80: 2.44). The model adds the two with no split, so k_d = k_s =
// 1 reflects more than 1 even on a flat ply (1.15 head-on at alpha = 1, up to about 1.5): it
// conserves energy for k_d + k_s <= 1 on flat plies, which is what the tests hold it to; k_d and
// k_s are the artist's albedos, not a budget.
//
// Functions return the four per-unit components: f = k_d * diffuse + k_s *
// specular, as eq. (7)-(8) separate them.

#include <Eigen/Core>

namespace psrig::cloth {

// T rho of eq. (2): "always 2 for fabrics".
inline constexpr float kFabricDensityThickness = 2;
// Eq. (1)'s w: the data set generator and both renderers take this one value
// (the data set file does not record it; chen2024 does not give it).
inline constexpr float kDefaultDiffuseBlend = 0.5f;

// f_s / k_s: the specular microflake lobe of a ply with normal n_p,
// orientation t_p (both unit) and roughness alpha. wi towards the light, wo
// towards the eye, unit. Symmetric in wi and wo.
[[nodiscard]] float woven_specular(const Eigen::Vector3f& wi, const Eigen::Vector3f& wo,
                                   const Eigen::Vector3f& normal,
                                   const Eigen::Vector3f& orientation, float alpha);

// f_d / k_d: the blended Lambertian, n_s = +z. Reciprocal only where w = 0
// or n_p = n_s.
[[nodiscard]] float woven_diffuse(const Eigen::Vector3f& wi, const Eigen::Vector3f& wo,
                                  const Eigen::Vector3f& normal,
                                  float diffuse_blend = kDefaultDiffuseBlend);

// The pieces of eq. (2), for tests and the curious.
[[nodiscard]] float microflake_distribution(const Eigen::Vector3f& h,
                                            const Eigen::Vector3f& orientation, float alpha);
[[nodiscard]] float microflake_projected_area(const Eigen::Vector3f& w,
                                              const Eigen::Vector3f& orientation, float alpha);

}  // namespace psrig::cloth
