#include "psrig/cloth/woven_aggregate.h"

#include <cmath>

namespace psrig::cloth {

namespace {

// Roberts' R2 sequence: the plastic number's generalised golden ratios.
constexpr double kR2a = 0.7548776662466927;
constexpr double kR2b = 0.5698402909980532;

}  // namespace

std::uint64_t SampleRandom::next() {
  std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

std::uint64_t mix_seed(std::uint64_t seed, std::uint64_t key) {
  SampleRandom random(seed ^ (key * 0xD1B54A32D192ED03ULL));
  random.next();
  return random.next();
}

WovenComponents woven_point_components(const WovenPoint& point, const Eigen::Vector3f& wi,
                                       const Eigen::Vector3f& wo, const WovenShading& shading) {
  if (point.yarn == YarnType::gap) return {};
  const bool warp = point.yarn == YarnType::warp;
  const float diffuse = woven_diffuse(wi, wo, point.normal, shading.diffuse_blend);
  const float specular = woven_specular(wi, wo, point.normal, point.orientation,
                                        warp ? shading.warp_alpha : shading.weft_alpha);
  WovenComponents c;
  (warp ? c.c_warp : c.c_weft) = diffuse;
  (warp ? c.s_warp : c.s_weft) = specular;
  return c;
}

Footprint footprint_in_repeats(const WovenSurface& surface, float u, float v, float size) {
  const Eigen::Vector2f repeat = surface.repeat_size();
  Footprint footprint;
  footprint.centre = {u * repeat.x(), v * repeat.y()};
  footprint.edge_u = {size * repeat.x(), 0};
  footprint.edge_v = {0, size * repeat.y()};
  return footprint;
}

FootprintSamples sample_footprint(const WovenSurface& surface, const Footprint& footprint,
                                  int count, std::uint64_t seed) {
  SampleRandom random(seed);
  const double shift_a = random.uniform(), shift_b = random.uniform();
  FootprintSamples samples;
  samples.points.reserve(static_cast<std::size_t>(count));
  samples.positions.reserve(static_cast<std::size_t>(count));
  samples.jacobian.reserve(static_cast<std::size_t>(count));
  for (int k = 0; k < count; ++k) {
    double a = shift_a + kR2a * (k + 1), b = shift_b + kR2b * (k + 1);
    a -= std::floor(a);
    b -= std::floor(b);
    const Eigen::Vector2f xy = footprint.centre + static_cast<float>(a - 0.5) * footprint.edge_u +
                               static_cast<float>(b - 0.5) * footprint.edge_v;
    const WovenPoint p = surface.point(xy);
    samples.points.push_back(p);
    samples.positions.emplace_back(xy.x(), xy.y(), p.height);
    samples.jacobian.push_back(1 / p.normal.z());
  }
  return samples;
}

std::vector<std::uint8_t> sample_visibility(const WovenSurface& surface,
                                            const FootprintSamples& samples,
                                            const Eigen::Vector3f& direction) {
  std::vector<std::uint8_t> visible(samples.points.size());
  for (std::size_t k = 0; k < visible.size(); ++k)
    visible[k] = samples.points[k].normal.dot(direction) > 0 &&
                 surface.visible(samples.positions[k], direction);
  return visible;
}

WovenComponents aggregate_samples(const FootprintSamples& samples,
                                  const std::vector<std::uint8_t>& visible_wi,
                                  const std::vector<std::uint8_t>& visible_wo,
                                  const Eigen::Vector3f& wi, const Eigen::Vector3f& wo,
                                  const WovenShading& shading) {
  double area = 0;
  double c_warp = 0, c_weft = 0, s_warp = 0, s_weft = 0;
  for (std::size_t k = 0; k < samples.points.size(); ++k) {
    if (!visible_wo[k]) continue;
    const WovenPoint& p = samples.points[k];
    const float projected = wo.dot(p.normal) * samples.jacobian[k];  // A(p, wo)
    if (projected <= 0) continue;
    area += projected;
    if (p.yarn == YarnType::gap || !visible_wi[k]) continue;
    const float lit = wi.dot(p.normal) * projected;  // <wi . n_p> A(p, wo)
    if (lit <= 0) continue;
    const bool warp = p.yarn == YarnType::warp;
    const float alpha = warp ? shading.warp_alpha : shading.weft_alpha;
    const double diffuse = lit * woven_diffuse(wi, wo, p.normal, shading.diffuse_blend);
    const double specular = lit * woven_specular(wi, wo, p.normal, p.orientation, alpha);
    (warp ? c_warp : c_weft) += diffuse;
    (warp ? s_warp : s_weft) += specular;
  }
  if (area <= 0) return {};
  return {static_cast<float>(c_warp / area), static_cast<float>(c_weft / area),
          static_cast<float>(s_warp / area), static_cast<float>(s_weft / area)};
}

namespace {

// What one direction alone decides for each sample: its cosine about n_p,
// L(w) of eq. (2), and whether it is seen (or lit).
struct DirectionTerms {
  std::vector<float> cosine, lambda;
  std::vector<std::uint8_t> visible;
};

DirectionTerms direction_terms(const WovenSurface& surface, const FootprintSamples& samples,
                               const Eigen::Vector3f& w, const WovenShading& shading) {
  DirectionTerms terms;
  terms.visible = sample_visibility(surface, samples, w);
  const std::size_t n = samples.points.size();
  terms.cosine.resize(n);
  terms.lambda.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const WovenPoint& p = samples.points[k];
    terms.cosine[k] = w.dot(p.normal);
    if (p.yarn == YarnType::gap || terms.cosine[k] <= 0) continue;
    const float alpha = p.yarn == YarnType::warp ? shading.warp_alpha : shading.weft_alpha;
    terms.lambda[k] = microflake_projected_area(w, p.orientation, alpha) / terms.cosine[k];
  }
  return terms;
}

constexpr float kPairsPi = 3.14159265358979f;

}  // namespace

std::vector<WovenComponents> aggregate_direction_pairs(const WovenSurface& surface,
                                                       const FootprintSamples& samples,
                                                       const std::vector<Eigen::Vector3f>& incoming,
                                                       const std::vector<Eigen::Vector3f>& outgoing,
                                                       const WovenShading& shading) {
  const std::size_t n = samples.points.size();
  std::vector<DirectionTerms> seen;
  std::vector<double> area(outgoing.size(), 0);
  seen.reserve(outgoing.size());
  for (std::size_t o = 0; o < outgoing.size(); ++o) {
    seen.push_back(direction_terms(surface, samples, outgoing[o], shading));
    // A(p, wo) in place of the cosine: <wo . n_p> / <n_s . n_p> V, 0 hidden.
    DirectionTerms& terms = seen.back();
    for (std::size_t k = 0; k < n; ++k) {
      const float projected = terms.cosine[k] * samples.jacobian[k];
      terms.visible[k] = terms.visible[k] && projected > 0;
      if (terms.visible[k]) area[o] += projected;
    }
  }
  std::vector<WovenComponents> result(incoming.size() * outgoing.size());
  std::vector<float> diffuse(n);
  for (std::size_t i = 0; i < incoming.size(); ++i) {
    const Eigen::Vector3f& wi = incoming[i];
    const DirectionTerms lit = direction_terms(surface, samples, wi, shading);
    for (std::size_t k = 0; k < n; ++k)
      diffuse[k] =
          (shading.diffuse_blend * lit.cosine[k] / wi.z() + (1 - shading.diffuse_blend)) / kPairsPi;
    for (std::size_t o = 0; o < outgoing.size(); ++o) {
      if (area[o] <= 0) continue;
      const DirectionTerms& eye = seen[o];
      const Eigen::Vector3f sum = wi + outgoing[o];
      const float length = sum.norm();
      if (length < 1e-6f) continue;
      const Eigen::Vector3f half = sum / length;
      double c_warp = 0, c_weft = 0, s_warp = 0, s_weft = 0;
      for (std::size_t k = 0; k < n; ++k) {
        const WovenPoint& p = samples.points[k];
        if (p.yarn == YarnType::gap || !eye.visible[k] || !lit.visible[k] || lit.cosine[k] <= 0)
          continue;
        const bool warp = p.yarn == YarnType::warp;
        const float alpha = warp ? shading.warp_alpha : shading.weft_alpha;
        const float projected = eye.cosine[k] * samples.jacobian[k];
        const float weight = lit.cosine[k] * projected;
        const float along = half.dot(p.orientation);
        const float q = 1 + (1 / (alpha * alpha) - 1) * along * along;
        const float lambda = lit.lambda[k] + eye.lambda[k];
        const float g = -std::expm1(-kFabricDensityThickness * lambda) / lambda;
        const float specular = g / (kPairsPi * alpha * q * q * 4 * lit.cosine[k] * eye.cosine[k]);
        (warp ? c_warp : c_weft) += static_cast<double>(weight * diffuse[k]);
        (warp ? s_warp : s_weft) += static_cast<double>(weight * specular);
      }
      result[i * outgoing.size() + o] = {
          static_cast<float>(c_warp / area[o]), static_cast<float>(c_weft / area[o]),
          static_cast<float>(s_warp / area[o]), static_cast<float>(s_weft / area[o])};
    }
  }
  return result;
}

WovenComponents aggregate_woven_bsdf(const WovenSurface& surface, const WovenShading& shading,
                                     const Footprint& footprint, const Eigen::Vector3f& wi,
                                     const Eigen::Vector3f& wo, int count, std::uint64_t seed) {
  const FootprintSamples samples = sample_footprint(surface, footprint, count, seed);
  return aggregate_samples(samples, sample_visibility(surface, samples, wi),
                           sample_visibility(surface, samples, wo), wi, wo, shading);
}

}  // namespace psrig::cloth
