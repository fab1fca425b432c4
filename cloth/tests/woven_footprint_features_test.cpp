// A footprint's features (the material's textures averaged over it, per
// yarn type): against the texels' overlap with the box summed directly,
// across the repeat's edges and over several repeats; and the warp and weft
// they tell apart against the surface that made the textures.
#include "psrig/cloth/woven_footprint_features.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "psrig/cloth/weave_rules.h"
#include "psrig/cloth/woven_dataset_generator.h"
#include "psrig/cloth/woven_surface.h"

namespace psrig::cloth {
namespace {

constexpr int kCount = woven_footprint_feature_count;

// A material of seeded random unit normals and orientations, some texels gaps.
WovenMaterialSample random_material(int size, std::uint32_t seed) {
  std::mt19937 random(seed);
  std::normal_distribution<float> normal;
  WovenMaterialSample material;
  material.texture_size = size;
  for (int texel = 0; texel < size * size; ++texel) {
    const bool gap = random() % 5 == 0;
    for (auto* texture : {&material.normal, &material.orientation}) {
      Eigen::Vector3f v(normal(random), normal(random), std::abs(normal(random)));
      v = gap ? Eigen::Vector3f::Zero() : Eigen::Vector3f(v.normalized());
      texture->insert(texture->end(), {v.x(), v.y(), v.z()});
    }
  }
  return material;
}

// The box's mean by each texel of every repeat it touches, weighted by
// the overlap's area: what the table must give.
std::array<double, kCount> direct_mean(const WovenMaterialSample& material, float u, float v,
                                       float size) {
  const int t = material.texture_size;
  const double width = std::max<double>(size * t, woven_footprint_smallest_texels);
  const double x0 = u * t - width / 2, y0 = v * t - width / 2;
  std::array<double, kCount> sum{};
  for (int row = static_cast<int>(std::floor(y0)); row < std::ceil(y0 + width); ++row) {
    for (int column = static_cast<int>(std::floor(x0)); column < std::ceil(x0 + width); ++column) {
      const double overlap =
          std::max(0.0, std::min<double>(column + 1, x0 + width) - std::max<double>(column, x0)) *
          std::max(0.0, std::min<double>(row + 1, y0 + width) - std::max<double>(row, y0));
      if (overlap <= 0) continue;
      // The texel's features: the table of a one-texel material holding it
      // (its one corner beyond the texel, (1, 1), is the texel's sum).
      const int tc = ((column % t) + t) % t, tr = ((row % t) + t) % t;
      const std::size_t at = (static_cast<std::size_t>(tr) * t + tc) * 3;
      WovenMaterialSample texel;
      texel.texture_size = 1;
      texel.normal.assign(&material.normal[at], &material.normal[at] + 3);
      texel.orientation.assign(&material.orientation[at], &material.orientation[at] + 3);
      const WovenFootprintFeatures features(texel);
      for (int k = 0; k < kCount; ++k)
        sum[static_cast<std::size_t>(k)] += overlap * features.table()[3 * kCount + k];
    }
  }
  for (double& s : sum)
    s /= width * width;
  return sum;
}

TEST(WovenFootprintFeatures, AreTheTexelsMeanOverTheBoxWhereverItLies) {
  const WovenMaterialSample material = random_material(16, 3);
  const WovenFootprintFeatures features(material);
  std::mt19937 random(7);
  std::uniform_real_distribution<float> position(-2.0F, 3.0F);
  const float sizes[] = {0.0F, 0.01F, 0.07F, 0.3F, 0.95F, 1.0F, 1.6F, 4.3F};
  for (float size : sizes) {
    for (int trial = 0; trial < 20; ++trial) {
      const float u = position(random), v = position(random);
      std::array<float, kCount> got{};
      features.mean(u, v, size, got);
      const std::array<double, kCount> want = direct_mean(material, u, v, size);
      // Floats: the table's sums (up to T^2) to about 1e-7 of themselves,
      // over the box's area.
      const float width = std::max(size * 16, woven_footprint_smallest_texels);
      const float tolerance = 1e-5F + 4e-7F * 256 / (width * width);
      for (int k = 0; k < kCount; ++k) {
        EXPECT_NEAR(got[static_cast<std::size_t>(k)], want[static_cast<std::size_t>(k)], tolerance)
            << "feature " << k << " at (" << u << ", " << v << ") size " << size;
      }
    }
  }
}

TEST(WovenFootprintFeatures, AWholeRepeatIsTheTexturesMeanAnywhere) {
  const WovenMaterialSample material = random_material(12, 11);
  const WovenFootprintFeatures features(material);
  std::array<float, kCount> first{}, other{};
  features.mean(0.5F, 0.5F, 1.0F, first);
  // The warp and weft shares are the texels not in gaps.
  int yarn = 0;
  for (std::size_t at = 0; at < material.orientation.size(); at += 3)
    yarn += material.orientation[at] != 0 || material.orientation[at + 1] != 0;
  EXPECT_NEAR(first[0] + first[1], yarn / 144.0, 1e-6);
  for (float u : {0.13F, 0.77F, -3.4F}) {
    features.mean(u, 1.0F - u, 1.0F, other);
    for (int k = 0; k < kCount; ++k)
      EXPECT_NEAR(other[static_cast<std::size_t>(k)], first[static_cast<std::size_t>(k)], 1e-5);
    features.mean(u, 0.25F, 3.0F, other);  // three repeats: the same mean
    for (int k = 0; k < kCount; ++k)
      EXPECT_NEAR(other[static_cast<std::size_t>(k)], first[static_cast<std::size_t>(k)], 1e-5);
  }
}

// The textures carry no yarn type: the features take it from the ply's
// orientation. Over the twists the data set draws (-30 to 0 degrees) and
// both ends of its inclinations, that is the surface's own yarn at every
// texel of a plain weave, a twill and a satin.
TEST(WovenFootprintFeatures, TellWarpFromWeftAsTheSurfaceDoes) {
  const int t = 32;
  for (const WeaveMatrix& weave : {plain_weave(), twill_weave(2, 2), satin_weave(5, 2)}) {
    for (float twist : {-30.0F, -15.0F, 0.0F}) {
      for (float inclination : {15.0F, 45.0F}) {
        WovenMaterialParameters parameters;
        parameters.shape.twist_deg = twist;
        parameters.shape.inclination_deg = inclination;
        auto material = generate_woven_material(weave, parameters, t);
        ASSERT_TRUE(material);
        auto surface = WovenSurface::make(weave, parameters.shape, 1, 1);
        ASSERT_TRUE(surface);
        const WovenFootprintFeatures features(*material);
        const Eigen::Vector2f repeat = surface->repeat_size();
        for (int row = 0; row < t; ++row) {
          for (int column = 0; column < t; ++column) {
            const YarnType yarn =
                surface->point({(column + 0.5F) / t * repeat.x(), (row + 0.5F) / t * repeat.y()})
                    .yarn;
            std::array<float, kCount> f{};
            features.mean((column + 0.5F) / t, (row + 0.5F) / t, 1.0F / t, f);
            EXPECT_NEAR(f[0], yarn == YarnType::warp ? 1 : 0, 1e-4)
                << weave.name << " twist " << twist << " texel " << column << ", " << row;
            EXPECT_NEAR(f[1], yarn == YarnType::weft ? 1 : 0, 1e-4)
                << weave.name << " twist " << twist << " texel " << column << ", " << row;
          }
        }
      }
    }
  }
}

}  // namespace
}  // namespace psrig::cloth
