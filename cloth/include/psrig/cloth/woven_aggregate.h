#pragma once
// The fabric's BSDF aggregated over a footprint (chen2024 eq. 3-5, after
// Zhu et al. 2023a), by Monte Carlo over points of the footprint with the
// yarns' mutual shadowing and masking (eq. 3 and 4's binary V, rays against
// woven_surface.h's height field), separated into eq. (7)'s four
// components:
//
//   f_P(wi, wo) = 1/A_P(wo) sum_p f_p(wi, wo) <wi . n_p> V(x_p, wi) A(p, wo) k_P(p)
//   A(p, wo)    = <wo . n_p> / <n_s . n_p> V(x_p, wo)
//   A_P(wo)     = sum_p A(p, wo) k_P(p)
//
// k_P is a box over the footprint (a parallelogram in the plane, a square
// for the data set), sampled by a randomly shifted R2 sequence (Roberts
// 2018: low discrepancy for any count). A_P is estimated from the same
// points, as a ratio; a gap's floor counts in A_P (it is seen, black) and
// reflects nothing, so holes darken a footprint as they would a pixel.
//
// f_P carries eq. (3)'s <wi . n_p>: the radiance a footprint sends to wo
// under a directional light of irradiance E (normal to the light) is
// E f_P. For a flat ply that is f <wi . n_s>, not f.
//
//   f_P = kd_warp c_warp + kd_weft c_weft + ks_warp s_warp + ks_weft s_weft

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "psrig/cloth/woven_bsdf.h"
#include "psrig/cloth/woven_components.h"
#include "psrig/cloth/woven_surface.h"

namespace psrig::cloth {

// The appearance parameters the geometry does not hold (beta lives in the
// surface): roughness per yarn type and eq. (1)'s diffuse blend.
struct WovenShading {
  float warp_alpha = 0.5f, weft_alpha = 0.5f;
  float diffuse_blend = kDefaultDiffuseBlend;
};

// Eq. (1) at one point in eq. (7)'s components: the yarn there (warp or
// weft) gets f_d / k_d and f_s / k_s with its own alpha, the other yarn
// type and a gap nothing. This is f itself, without eq. (3)'s <wi . n_p>.
[[nodiscard]] WovenComponents woven_point_components(const WovenPoint& point,
                                                     const Eigen::Vector3f& wi,
                                                     const Eigen::Vector3f& wo,
                                                     const WovenShading& shading);

// A patch of the plane, spacings: centre + a e_u + b e_v for a, b in
// [-1/2, 1/2].
struct Footprint {
  Eigen::Vector2f centre = Eigen::Vector2f::Zero();
  Eigen::Vector2f edge_u = Eigen::Vector2f::UnitX(), edge_v = Eigen::Vector2f::UnitY();
};

// WovenQuery's footprint: centre (u, v) and width `size` in repeats, so a
// square of the repeat's texture (a rectangle of spacings where the repeat
// is not square, as satin 5x10's).
[[nodiscard]] Footprint footprint_in_repeats(const WovenSurface& surface, float u, float v,
                                             float size);

// The points eq. (3) sums over, drawn once for a footprint and shared by
// every pair of directions asked of it.
struct FootprintSamples {
  std::vector<WovenPoint> points;
  std::vector<Eigen::Vector3f> positions;  // x_p
  std::vector<float> jacobian;             // 1 / <n_s . n_p>
};
[[nodiscard]] FootprintSamples sample_footprint(const WovenSurface& surface,
                                                const Footprint& footprint, int count,
                                                std::uint64_t seed);

// V(x_p, w) for each sample, 1 or 0.
[[nodiscard]] std::vector<std::uint8_t> sample_visibility(const WovenSurface& surface,
                                                          const FootprintSamples& samples,
                                                          const Eigen::Vector3f& direction);

// Eq. (3) over the samples with their visibilities towards wi and wo. A
// footprint that shows wo nothing (A_P = 0) gives zeros.
[[nodiscard]] WovenComponents aggregate_samples(const FootprintSamples& samples,
                                                const std::vector<std::uint8_t>& visible_wi,
                                                const std::vector<std::uint8_t>& visible_wo,
                                                const Eigen::Vector3f& wi,
                                                const Eigen::Vector3f& wo,
                                                const WovenShading& shading);

// Eq. (3) for every pair of `incoming` x `outgoing` directions over one
// footprint's samples, wi-major (pair i * outgoing.size() + o): the same
// sums as aggregate_samples, what each direction alone decides (V, A,
// L(w), the diffuse lobe) worked out once per direction rather than per
// pair; the data set generator's loop.
[[nodiscard]] std::vector<WovenComponents> aggregate_direction_pairs(
    const WovenSurface& surface, const FootprintSamples& samples,
    const std::vector<Eigen::Vector3f>& incoming, const std::vector<Eigen::Vector3f>& outgoing,
    const WovenShading& shading);

// One query from scratch: `count` samples (chen2024: 2048).
[[nodiscard]] WovenComponents aggregate_woven_bsdf(
    const WovenSurface& surface, const WovenShading& shading, const Footprint& footprint,
    const Eigen::Vector3f& wi, const Eigen::Vector3f& wo, int count, std::uint64_t seed);

// Seeds that do not depend on the order anything runs in: splitmix64 of the
// seed mixed with each key in turn.
[[nodiscard]] std::uint64_t mix_seed(std::uint64_t seed, std::uint64_t key);

// A small, fast generator for the Monte Carlo (splitmix64), uniform floats
// in [0, 1).
class SampleRandom {
 public:
  explicit SampleRandom(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next();
  float uniform() { return static_cast<float>(next() >> 40) * 0x1.0p-24f; }

 private:
  std::uint64_t state_;
};

}  // namespace psrig::cloth
