#include "woven_standin.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <random>

namespace psrig::test {
namespace {

struct StandinWeave {
  const char* name;
  int repeat;
  int step;  // warp up where (x * step + y) % repeat < ups
  int ups;
};

constexpr std::array<StandinWeave, 4> standin_weaves{
    {{"plain", 2, 1, 1}, {"2/1 twill", 3, 1, 2}, {"3/1 twill", 4, 1, 3}, {"5-end satin", 5, 2, 1}}};

bool warp_up(const StandinWeave& weave, int cell_x, int cell_y) {
  return (cell_x * weave.step + cell_y) % weave.repeat < weave.ups;
}

// The warp share of a box `width` repeats wide around (u, v), wrapped.
float warp_share(const cloth::WovenMaterialSample& material, float u, float v, float width) {
  const int t = material.texture_size;
  const int half = std::max(0, static_cast<int>(std::lround(width * static_cast<float>(t) / 2)));
  const int span = std::min(half, t);  // past a repeat the share is the whole repeat's
  const int cx = static_cast<int>(std::floor(u * static_cast<float>(t)));
  const int cy = static_cast<int>(std::floor(v * static_cast<float>(t)));
  float warp = 0, all = 0;
  for (int dy = -span; dy <= span; ++dy) {
    for (int dx = -span; dx <= span; ++dx) {
      const int x = ((cx + dx) % t + t) % t, y = ((cy + dy) % t + t) % t;
      warp += material.orientation[(static_cast<std::size_t>(y) * t + x) * 3 + 1];
      all += 1;
    }
  }
  return warp / all;
}

std::array<float, 3> upper_direction(std::mt19937_64& random) {
  std::uniform_real_distribution<float> uniform(-1.0F, 1.0F);
  for (;;) {
    const float x = uniform(random), y = uniform(random);
    if (x * x + y * y < 0.95F) {
      return {x, y, std::sqrt(1.0F - x * x - y * y)};
    }
  }
}

float lobe(const std::array<float, 3>& h, float tx, float ty, float alpha, float beta) {
  const float along = h[0] * tx + h[1] * ty;
  return std::exp(-along * along / (2 * alpha * alpha)) * std::pow(h[2], 4.0F) * (1 + beta / 4) /
         (4 * alpha);
}

}  // namespace

cloth::WovenMaterialSample analytic_woven_material(int kind, int texture_size, float roughness,
                                                   float height_scale) {
  const StandinWeave& weave =
      standin_weaves[static_cast<std::size_t>(kind) % standin_weaves.size()];
  cloth::WovenMaterialSample material;
  material.pattern = weave.name;
  material.texture_size = texture_size;
  material.roughness = roughness;
  material.height_scale = height_scale;
  const auto texels = static_cast<std::size_t>(texture_size) * texture_size;
  material.normal.resize(texels * 3);
  material.orientation.resize(texels * 3);
  const float cell = static_cast<float>(texture_size) / static_cast<float>(weave.repeat);
  for (int y = 0; y < texture_size; ++y) {
    for (int x = 0; x < texture_size; ++x) {
      const float fx = static_cast<float>(x) + 0.5F, fy = static_cast<float>(y) + 0.5F;
      const int cx = static_cast<int>(fx / cell), cy = static_cast<int>(fy / cell);
      const bool warp = warp_up(weave, cx, cy);
      // The float's slope across its cell: a cosine arch along the yarn.
      const float along = (warp ? fy : fx) / cell;
      const float tilt = 0.4F * height_scale * std::sin(2 * std::numbers::pi_v<float> * along);
      std::array<float, 3> n = warp ? std::array{0.0F, -tilt, 1.0F} : std::array{-tilt, 0.0F, 1.0F};
      const float length = std::hypot(n[0], n[1], n[2]);
      const std::size_t at = (static_cast<std::size_t>(y) * texture_size + x) * 3;
      for (int c = 0; c < 3; ++c) {
        material.normal[at + c] = n[c] / length;
      }
      material.orientation[at + 0] = warp ? 0.0F : 1.0F;
      material.orientation[at + 1] = warp ? 1.0F : 0.0F;
      material.orientation[at + 2] = 0.0F;
    }
  }
  return material;
}

cloth::WovenDataset analytic_woven_dataset(int materials, int queries_per_material,
                                           int texture_size, std::uint64_t seed) {
  cloth::WovenDataset dataset;
  dataset.seed = seed;
  dataset.command = "psrig::test::analytic_woven_dataset";
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<float> unit(0.0F, 1.0F);
  for (int m = 0; m < materials; ++m) {
    dataset.materials.push_back(
        analytic_woven_material(m, texture_size, 0.1F + 0.9F * unit(random), 2.0F * unit(random)));
  }
  for (int m = 0; m < materials; ++m) {
    const cloth::WovenMaterialSample& material = dataset.materials[static_cast<std::size_t>(m)];
    for (int q = 0; q < queries_per_material; ++q) {
      cloth::WovenQuery query;
      query.material = static_cast<std::uint32_t>(m);
      query.u = unit(random);
      query.v = unit(random);
      // Half the footprints under a repeat, half up to five (5.1).
      query.size = unit(random) < 0.5F ? unit(random) : 1.0F + 4.0F * unit(random);
      query.wi = upper_direction(random);
      query.wo = upper_direction(random);
      std::array<float, 3> h{query.wi[0] + query.wo[0], query.wi[1] + query.wo[1],
                             query.wi[2] + query.wo[2]};
      const float length = std::hypot(h[0], h[1], h[2]);
      for (float& c : h)
        c /= length;
      const float w = warp_share(material, query.u, query.v, query.size);
      const float cos_i = query.wi[2] / std::numbers::pi_v<float>;
      query.c_warp = w * cos_i;
      query.c_weft = (1 - w) * cos_i;
      query.s_warp = w * lobe(h, 0, 1, material.roughness, material.height_scale);
      query.s_weft = (1 - w) * lobe(h, 1, 0, material.roughness, material.height_scale);
      dataset.queries.push_back(query);
    }
  }
  return dataset;
}

}  // namespace psrig::test
