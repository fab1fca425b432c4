// Woven cloth at thread level (issue 5): every crossing as the weave matrix
// says, and a satin's front and back showing different threads.
#include <gtest/gtest.h>

#include "psrig/cloth/knit_fabric.h"
#include "psrig/cloth/woven_fabric.h"
#include "test_support.h"

namespace psrig::cloth {
namespace {

// z of a thread's sample nearest to (x, y) seen from the front.
float depth_at(const YarnCurve& curve, float x, float y) {
  float best = 1e9f, z = 0;
  for (const Eigen::Vector3f& p : curve.points) {
    const float distance = (p.head<2>() - Eigen::Vector2f(x, y)).squaredNorm();
    if (distance < best) {
      best = distance;
      z = p.z();
    }
  }
  return z;
}

TEST(WovenGeometry, EveryCrossingAsTheMatrixSays) {
  for (const char* name : {"plain.weave", "twill-2x2.weave", "satin-5.weave"}) {
    const auto weave = load_weave_matrix(test::shipped_pattern(name));
    ASSERT_TRUE(weave) << weave.error().describe();
    const WovenParameters parameters;
    const StitchMesh mesh = woven_mesh(10, 10, parameters);
    YarnSet yarns;
    weave_yarns(*weave, mesh, parameters, yarns);
    ASSERT_EQ(yarns.curves.size(), 20U);
    for (int warp = 0; warp < 10; ++warp)
      for (int weft = 0; weft < 10; ++weft) {
        const Eigen::Vector3f centre = mesh.point(warp, weft, 0.5f, 0.5f);
        const float warp_z = depth_at(yarns.curves[warp], centre.x(), centre.y());
        const float weft_z = depth_at(yarns.curves[10 + weft], centre.x(), centre.y());
        EXPECT_EQ(warp_z > weft_z, weave->warp_over(warp, weft))
            << name << " " << warp << ", " << weft;
        EXPECT_NEAR(std::abs(warp_z - weft_z), 2 * parameters.style.radius_mm, 1e-3f);
      }
  }
}

TEST(WovenGeometry, SatinShowsOneThreadInFrontAndTheOtherBehind) {
  const auto weave = load_weave_matrix(test::shipped_pattern("satin-5.weave"));
  ASSERT_TRUE(weave);
  const WovenParameters parameters;
  YarnSet yarns;
  weave_yarns(*weave, woven_mesh(10, 10, parameters), parameters, yarns);
  // Mean depth of warps and of wefts: one set floats on each face.
  double warp = 0, weft = 0;
  for (int i = 0; i < 10; ++i) {
    for (const Eigen::Vector3f& p : yarns.curves[i].points)
      warp += p.z();
    for (const Eigen::Vector3f& p : yarns.curves[10 + i].points)
      weft += p.z();
  }
  EXPECT_LT(warp * weft, 0.0);
}

TEST(KnitLayout, ChartTiledWithItsColours) {
  const auto chart = load_stitch_chart(test::shipped_pattern("stripes.chart"));
  ASSERT_TRUE(chart) << chart.error().describe();
  const KnitLayout layout = tile_chart(*chart, 7, 9);
  ASSERT_EQ(layout.purl.size(), 63U);
  ASSERT_EQ(layout.colours.size(), 63U);
  for (int row = 0; row < 9; ++row)
    for (int column = 0; column < 7; ++column) {
      EXPECT_EQ(layout.is_purl(column, row), chart->at(column, row) == Stitch::purl);
      EXPECT_EQ(layout.colours[row * 7 + column], chart->palette[chart->colour_at(column, row)]);
    }
  const auto rib = load_stitch_chart(test::shipped_pattern("rib-2x2.chart"));
  ASSERT_TRUE(rib);
  const KnitLayout ribbed = tile_chart(*rib, 8, 2);
  EXPECT_TRUE(ribbed.colours.empty());
  EXPECT_EQ(ribbed.purl,
            (std::vector<std::uint8_t>{0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1, 1}));
}

}  // namespace
}  // namespace psrig::cloth
