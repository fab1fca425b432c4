#include "psrig/cloth/woven_footprint_features.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace psrig::cloth {
namespace {

constexpr int kFeatures = woven_footprint_feature_count;

// One texel's features (the header's order).
std::array<float, kFeatures> texel_features(const float* normal, const float* orientation) {
  std::array<float, kFeatures> f{};
  const float along_weft = std::abs(orientation[0]), along_warp = std::abs(orientation[1]);
  if (along_weft == 0 && along_warp == 0) return f;  // a gap
  const bool warp = along_warp >= along_weft;
  const float nx = normal[0], ny = normal[1], nz = normal[2];
  const int type = warp ? 0 : 1;
  f[type] = 1;
  f[2 + 3 * type + 0] = nx;
  f[2 + 3 * type + 1] = ny;
  f[2 + 3 * type + 2] = nz;
  f[8 + 2 * type + 0] = nx * nx;
  f[8 + 2 * type + 1] = ny * ny;
  return f;
}

}  // namespace

WovenFootprintFeatures::WovenFootprintFeatures(const WovenMaterialSample& material)
    : size_(material.texture_size) {
  const int t = size_, corners = t + 1;
  std::vector<double> sums(static_cast<std::size_t>(corners) * corners * kFeatures, 0.0);
  auto at = [&](int column, int row) {
    return (static_cast<std::size_t>(row) * corners + column) * kFeatures;
  };
  for (int row = 0; row < t; ++row) {
    for (int column = 0; column < t; ++column) {
      const std::size_t texel = (static_cast<std::size_t>(row) * t + column) * 3;
      const auto f = texel_features(&material.normal[texel], &material.orientation[texel]);
      const std::size_t out = at(column + 1, row + 1), left = at(column, row + 1),
                        up = at(column + 1, row), diagonal = at(column, row);
      for (int k = 0; k < kFeatures; ++k)
        sums[out + k] = f[k] + sums[left + k] + sums[up + k] - sums[diagonal + k];
    }
  }
  table_.assign(sums.begin(), sums.end());
}

void WovenFootprintFeatures::corner_sum(float x, float y, std::span<float> out) const {
  const int t = size_, corners = t + 1;
  const int i = std::clamp(static_cast<int>(std::floor(x)), 0, t - 1);
  const int j = std::clamp(static_cast<int>(std::floor(y)), 0, t - 1);
  const float a = x - static_cast<float>(i), b = y - static_cast<float>(j);
  const float* c00 = &table_[(static_cast<std::size_t>(j) * corners + i) * kFeatures];
  const float* c10 = c00 + kFeatures;
  const float* c01 = c00 + static_cast<std::size_t>(corners) * kFeatures;
  const float* c11 = c01 + kFeatures;
  for (int k = 0; k < kFeatures; ++k) {
    const float top = c00[k] + a * (c10[k] - c00[k]);
    const float bottom = c01[k] + a * (c11[k] - c01[k]);
    out[k] = top + b * (bottom - top);
  }
}

void WovenFootprintFeatures::tiled_sum(float x, float y, std::span<float> out) const {
  const auto t = static_cast<float>(size_);
  const float kx = std::floor(x / t), ky = std::floor(y / t);
  const float fx = std::clamp(x - kx * t, 0.0F, t), fy = std::clamp(y - ky * t, 0.0F, t);
  std::array<float, kFeatures> whole, column, row, part;
  corner_sum(t, t, whole);
  corner_sum(t, fy, column);
  corner_sum(fx, t, row);
  corner_sum(fx, fy, part);
  for (int k = 0; k < kFeatures; ++k)
    out[k] = kx * ky * whole[k] + kx * column[k] + ky * row[k] + part[k];
}

void WovenFootprintFeatures::mean(float u, float v, float size, std::span<float> out) const {
  const auto t = static_cast<float>(size_);
  const float width = std::max(size * t, woven_footprint_smallest_texels);
  // The box's low corner moved into the first repeat: the sums stay small.
  float x0 = u * t - 0.5F * width, y0 = v * t - 0.5F * width;
  x0 -= std::floor(x0 / t) * t;
  y0 -= std::floor(y0 / t) * t;
  const float x1 = x0 + width, y1 = y0 + width;
  std::array<float, kFeatures> s11, s01, s10, s00;
  tiled_sum(x1, y1, s11);
  tiled_sum(x0, y1, s01);
  tiled_sum(x1, y0, s10);
  tiled_sum(x0, y0, s00);
  const float area = width * width;
  for (int k = 0; k < kFeatures; ++k)
    out[k] = (s11[k] - s01[k] - s10[k] + s00[k]) / area;
}

}  // namespace psrig::cloth
