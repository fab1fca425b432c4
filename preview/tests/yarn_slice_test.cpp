// The yarn's slice (the lumislice the renderer sweeps along each yarn):
// seamless along the yarn, its core covered and its halo sparse, the
// plies where the twist puts them, and mipmaps that average as chen2003
// eq. 11 does (colour weighted by density, density averaged).

#include "psrig/preview/yarn_slice.h"

#include <cmath>

#include <gtest/gtest.h>

namespace psrig::preview {
namespace {

YarnSliceOptions small_options() {
  YarnSliceOptions options;
  options.width = 64;
  options.height = 128;
  return options;
}

const std::array<std::uint8_t, 4>& texel(const YarnSliceLevel& level, int i, int j) {
  return level.texels[static_cast<std::size_t>(j * level.width + i)];
}

float across_of(const YarnSlice& slice, int i, int width) {
  return ((i + 0.5f) / static_cast<float>(width) * 2 - 1) * (1 + slice.halo);
}

TEST(YarnSlice, MipmapsAverageColourByDensity) {
  const YarnSlice slice = bake_yarn_slice({}, small_options());
  ASSERT_GE(slice.levels.size(), 7U);
  EXPECT_EQ(slice.levels.back().width, 1);
  EXPECT_EQ(slice.levels.back().height, 1);
  for (std::size_t l = 0; l + 1 < slice.levels.size(); ++l) {
    const YarnSliceLevel& fine = slice.levels[l];
    const YarnSliceLevel& coarse = slice.levels[l + 1];
    EXPECT_EQ(coarse.width, std::max(fine.width / 2, 1));
    for (int j = 0; j < coarse.height; j += 3)
      for (int i = 0; i < coarse.width; i += 3) {
        double density = 0, light = 0, tilt = 0;
        for (int dj = 0; dj < 2; ++dj)
          for (int di = 0; di < 2; ++di) {
            const SliceSample s = decode_texel(
                texel(fine, std::min(2 * i + di, fine.width - 1), std::min(2 * j + dj, fine.height - 1)));
            density += s.density / 4;
            light += s.density * s.light / 4;
            tilt += s.density * s.tilt_sin / 4;
          }
        const SliceSample got = decode_texel(texel(coarse, i, j));
        EXPECT_NEAR(got.density, density, 1.0 / 255) << "level " << l + 1;
        if (density > 0.2) {
          EXPECT_NEAR(got.light, light / density, 0.03) << "level " << l + 1;
          EXPECT_NEAR(got.tilt_sin, tilt / density, 0.03) << "level " << l + 1;
        }
      }
  }
}

TEST(YarnSlice, CoreIsCoveredHaloIsSparseAndGoesWithTheHairiness) {
  cloth::YarnStyle style;
  const YarnSliceOptions options = small_options();
  const auto halo_density = [&](const YarnSlice& slice) {
    const YarnSliceLevel& level = slice.levels[0];
    double sum = 0;
    int count = 0;
    for (int j = 0; j < level.height; ++j)
      for (int i = 0; i < level.width; ++i) {
        const float across = std::abs(across_of(slice, i, level.width));
        const float density = decode_texel(texel(level, i, j)).density;
        if (across <= 0.98f) {
          EXPECT_EQ(density, 1.0f) << i << ", " << j;
        }
        if (across > 1.02f) sum += density, ++count;
      }
    return sum / count;
  };
  const double hairy = halo_density(bake_yarn_slice(style, options));
  EXPECT_GT(hairy, 0.01);
  EXPECT_LT(hairy, 0.5);
  style.hairiness = 3;
  EXPECT_GT(halo_density(bake_yarn_slice(style, options)), 1.5 * hairy);
  style.hairiness = 0;
  EXPECT_EQ(halo_density(bake_yarn_slice(style, options)), 0.0);
  // The outermost columns are empty: the strip fades out, not cut off.
  const YarnSlice plain = bake_yarn_slice({}, options);
  const YarnSliceLevel& level = plain.levels[0];
  for (int j = 0; j < level.height; ++j) EXPECT_LT(texel(level, 0, j)[3], 128);
}

TEST(YarnSlice, RepeatsSeamlesslyAlongTheYarn) {
  const YarnSlice slice = bake_yarn_slice({}, small_options());
  const YarnSliceLevel& level = slice.levels[0];
  const auto row_difference = [&](int a, int b) {
    double sum = 0;
    for (int i = 0; i < level.width; ++i)
      for (int c = 0; c < 4; ++c)
        sum += std::abs(int(texel(level, i, a)[c]) - int(texel(level, i, b)[c]));
    return sum;
  };
  double neighbours = 0;
  for (int j = 0; j + 1 < level.height; ++j) neighbours += row_difference(j, j + 1);
  neighbours /= level.height - 1;
  EXPECT_LT(row_difference(level.height - 1, 0), 2 * neighbours) << "the last row meets the first";
  EXPECT_NEAR(slice.period_mm, 2 * cloth::YarnStyle{}.twist_pitch_mm, 1e-6f);
}

TEST(YarnSlice, PliesComeRoundEveryTurnOverThePlies) {
  cloth::YarnStyle style;
  style.plies = 2;
  style.hairiness = 0;
  const YarnSliceOptions options = small_options();
  const YarnSlice slice = bake_yarn_slice(style, options);
  const YarnSliceLevel& level = slice.levels[0];
  // Half a twist pitch on, the other ply stands where the first stood: the
  // ply offset (geometry, not the fibres' stripes) is the same.
  const int shift = static_cast<int>(std::lround(level.height * style.twist_pitch_mm / 2 / slice.period_mm));
  int compared = 0, grooves = 0;
  for (int j = 0; j < level.height; ++j)
    for (int i = 0; i < level.width; ++i) {
      if (std::abs(across_of(slice, i, level.width)) > 0.95f) continue;
      const SliceSample a = decode_texel(texel(level, i, j));
      const SliceSample b = decode_texel(texel(level, i, (j + shift) % level.height));
      EXPECT_NEAR(a.ply_offset, b.ply_offset, 0.1f) << i << ", " << j;
      ++compared;
      grooves += a.light < 0.5f;
    }
  EXPECT_GT(compared, 1000);
  EXPECT_GT(grooves, compared / 50) << "dark grooves between the plies";
  EXPECT_LT(grooves, compared / 2);
  EXPECT_GT(slice.core_mean.light, 0.4f);
  EXPECT_LT(slice.core_mean.light, 1.0f);
}

TEST(YarnSlice, BilinearSampleAtATexelCentreIsThatTexel) {
  const YarnSlice slice = bake_yarn_slice({}, small_options());
  const YarnSliceLevel& level = slice.levels[1];
  for (const auto& [i, j] : {std::pair{3, 5}, std::pair{20, 40}, std::pair{31, 63}}) {
    const SliceSample sample = sample_slice(slice, 1, (i + 0.5f) / level.width, (j + 0.5f) / level.height);
    const SliceSample expected = decode_texel(texel(level, i, j));
    EXPECT_NEAR(sample.density, expected.density, 1e-5f);
    EXPECT_NEAR(sample.light, expected.light, 1e-4f);
  }
  EXPECT_FLOAT_EQ(slice_u(slice, -(1 + slice.halo)), 0);
  EXPECT_FLOAT_EQ(slice_u(slice, 0), 0.5f);
  EXPECT_FLOAT_EQ(slice_u(slice, 1 + slice.halo), 1);
  EXPECT_FLOAT_EQ(slice_v(slice, slice.period_mm), 1);
}

TEST(YarnSlice, ColourDoesNotEnterIt) {
  cloth::YarnStyle a, b;
  b.colour = {0.1f, 0.9f, 0.2f};
  EXPECT_TRUE(same_slice(a, b));
  b.plies = 3;
  EXPECT_FALSE(same_slice(a, b));
}

}  // namespace
}  // namespace psrig::preview
