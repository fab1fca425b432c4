// The neural woven BSDF's data set generator (chen2024 5.1, Table 2): the
// materials' textures, the queries' layout and ranges, and the same bytes
// from the same seed on any number of threads.
#include "psrig/cloth/woven_dataset_generator.h"

#include <cmath>
#include <cstring>

#include <gtest/gtest.h>

#include "psrig/base/parallel.h"
#include "psrig/cloth/weave_rules.h"

namespace psrig::cloth {
namespace {

WovenDatasetOptions small_options() {
  WovenDatasetOptions options;
  options.texture_size = 32;
  options.centre_grid = 2;
  options.small_sizes = 2;
  options.large_sizes = 1;
  options.direction_grid = 3;
  options.samples = 64;
  options.shapes_per_pattern = 1;
  options.appearances_per_shape = 2;
  return options;
}

// The queries as bytes, to compare two runs exactly.
std::vector<unsigned char> bytes_of(const WovenDataset& dataset) {
  std::vector<unsigned char> bytes;
  for (const WovenQuery& q : dataset.queries) {
    const float values[] = {
        q.u,     q.v,     q.size,   q.wi[0],  q.wi[1],  q.wi[2],  q.wo[0],
        q.wo[1], q.wo[2], q.c_warp, q.c_weft, q.s_warp, q.s_weft, static_cast<float>(q.material)};
    const auto* p = reinterpret_cast<const unsigned char*>(values);
    bytes.insert(bytes.end(), p, p + sizeof values);
  }
  for (const WovenMaterialSample& m : dataset.materials) {
    const auto* n = reinterpret_cast<const unsigned char*>(m.normal.data());
    bytes.insert(bytes.end(), n, n + m.normal.size() * sizeof(float));
    const float values[] = {m.roughness, m.height_scale, m.twist_deg, m.inclination_deg};
    const auto* p = reinterpret_cast<const unsigned char*>(values);
    bytes.insert(bytes.end(), p, p + sizeof values);
  }
  return bytes;
}

TEST(WovenDatasetGenerator, MaterialsAreTheWeavesTexturesWithTable2sParameters) {
  const WovenDatasetOptions options = small_options();
  auto dataset = generate_woven_dataset({plain_weave(), satin_weave(5, 2, 2)}, options, 7);
  ASSERT_TRUE(dataset) << dataset.error().describe();
  ASSERT_EQ(dataset->materials.size(), 4U);
  EXPECT_EQ(dataset->seed, 7U);
  for (const WovenMaterialSample& m : dataset->materials) {
    EXPECT_EQ(m.texture_size, 32);
    ASSERT_EQ(m.normal.size(), 32U * 32 * 3);
    ASSERT_EQ(m.orientation.size(), 32U * 32 * 3);
    EXPECT_GE(m.roughness, 0.1f);
    EXPECT_LE(m.roughness, 1.0f);
    EXPECT_GE(m.height_scale, 0.0f);
    EXPECT_LE(m.height_scale, 2.0f);
    EXPECT_TRUE(m.twist_deg == -30 || m.twist_deg == 0 || m.twist_deg == 30);
    EXPECT_GE(m.inclination_deg, 15.0f);
    EXPECT_LE(m.inclination_deg, 45.0f);
    int gaps = 0;
    for (std::size_t t = 0; t < m.normal.size(); t += 3) {
      const Eigen::Vector3f n(m.normal[t], m.normal[t + 1], m.normal[t + 2]);
      const Eigen::Vector3f o(m.orientation[t], m.orientation[t + 1], m.orientation[t + 2]);
      if (n.isZero()) {
        EXPECT_TRUE(o.isZero());
        ++gaps;
        continue;
      }
      EXPECT_NEAR(n.norm(), 1, 1e-5f);
      EXPECT_GT(n.z(), 0);
      EXPECT_NEAR(o.norm(), 1, 1e-5f);
      EXPECT_NEAR(o.dot(n), 0, 1e-5f);
    }
    // Gaps are 0.2 x 0.2 of each cell: 4 % of the texels, give or take
    // the texels' grid.
    EXPECT_NEAR(gaps / (32.0 * 32.0), 0.04, 0.025) << m.pattern;
  }
  // Two appearances of one shape share its textures.
  EXPECT_EQ(dataset->materials[0].normal, dataset->materials[1].normal);
  EXPECT_NE(dataset->materials[0].roughness, dataset->materials[1].roughness);
}

TEST(WovenDatasetGenerator, QueriesCoverTheCentresSizesAndDirections) {
  const WovenDatasetOptions options = small_options();
  WovenMaterialParameters parameters;
  parameters.alpha = 0.4f;
  parameters.beta = 1.2f;
  auto queries = generate_woven_queries(twill_weave(2, 2), parameters, 3, options, 11);
  ASSERT_TRUE(queries) << queries.error().describe();
  ASSERT_FALSE(queries->empty());
  // 4 centres x 3 sizes footprints, each every pair of its directions
  // (3 x 3 strata, those in the disc: 5 to 9 each).
  EXPECT_GE(queries->size(), 4U * 3 * 25);
  EXPECT_LE(queries->size(), 4U * 3 * 81);
  int small = 0, large = 0, lit = 0;
  for (const WovenQuery& q : *queries) {
    EXPECT_EQ(q.material, 3U);
    EXPECT_GE(q.u, 0.0f);
    EXPECT_LT(q.u, 1.0f);
    EXPECT_GE(q.v, 0.0f);
    EXPECT_LT(q.v, 1.0f);
    EXPECT_GE(q.size, 0.0f);
    EXPECT_LE(q.size, 5.0f);
    (q.size <= 1 ? small : large)++;
    const Eigen::Vector3f wi(q.wi[0], q.wi[1], q.wi[2]), wo(q.wo[0], q.wo[1], q.wo[2]);
    EXPECT_NEAR(wi.norm(), 1, 1e-5f);
    EXPECT_NEAR(wo.norm(), 1, 1e-5f);
    EXPECT_GT(wi.z(), 0);
    EXPECT_GT(wo.z(), 0);
    for (float c : {q.c_warp, q.c_weft, q.s_warp, q.s_weft}) {
      EXPECT_GE(c, 0.0f);
      EXPECT_TRUE(std::isfinite(c));
    }
    if (q.c_warp + q.c_weft > 0) ++lit;
  }
  EXPECT_GT(small, large);  // two small sizes to one large
  EXPECT_GT(lit, static_cast<int>(queries->size()) * 9 / 10);
}

TEST(WovenDatasetGenerator, TheSameSeedGivesTheSameBytesOnAnyNumberOfThreads) {
  const WovenDatasetOptions options = small_options();
  const std::vector<WeaveMatrix> patterns = {plain_weave(), twill_weave(3, 1)};
  const int threads = thread_count();
  set_thread_count(1);
  auto one = generate_woven_dataset(patterns, options, 2024);
  set_thread_count(2);
  auto two = generate_woven_dataset(patterns, options, 2024);
  set_thread_count(threads);
  auto other = generate_woven_dataset(patterns, options, 2025);
  ASSERT_TRUE(one && two && other);
  EXPECT_EQ(bytes_of(*one), bytes_of(*two));
  EXPECT_NE(bytes_of(*one), bytes_of(*other));
}

TEST(WovenDatasetGenerator, BadOptionsAreBadInput) {
  WovenDatasetOptions options = small_options();
  options.samples = 0;
  EXPECT_FALSE(generate_woven_queries(plain_weave(), {}, 0, options, 1));
  options = small_options();
  options.max_size = 0.5f;
  EXPECT_FALSE(generate_woven_queries(plain_weave(), {}, 0, options, 1));
  EXPECT_FALSE(generate_woven_material(plain_weave(), {}, 0));
}

}  // namespace
}  // namespace psrig::cloth
