// Woven cloth at thread level (issues 5 and 18): every crossing as the
// weave matrix says with the threads touching there, a satin's faces, the
// density in physical units, plain weave covered by thread, and threads
// that never pass through each other deformed.
#include <gtest/gtest.h>

#include "psrig/cloth/knit_fabric.h"
#include "psrig/cloth/woven_fabric.h"
#include "psrig/cloth/yarn_clearance.h"
#include "psrig/cloth/yarn_raster.h"
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

WovenFabric woven(const char* name, int warps, int wefts, WovenParameters parameters = {}) {
  const auto weave = load_weave_matrix(test::shipped_pattern(name));
  EXPECT_TRUE(weave) << weave.error().describe();
  auto fabric = WovenFabric::build(*weave, warps, wefts, parameters);
  EXPECT_TRUE(fabric) << fabric.error().describe();
  return std::move(*fabric);
}

TEST(WovenGeometry, EveryCrossingAsTheMatrixSaysThreadsTouchingThere) {
  for (const char* name : {"plain.weave", "twill-2x2.weave", "satin-5.weave"}) {
    WovenFabric fabric = woven(name, 10, 10);
    const StitchMesh mesh = fabric.mesh();
    YarnSet yarns;
    fabric.update(mesh, yarns);
    ASSERT_EQ(yarns.curves.size(), 20U);
    for (int warp = 1; warp < 9; ++warp)
      for (int weft = 1; weft < 9; ++weft) {
        const Eigen::Vector3f centre = mesh.point(warp, weft, 0.5f, 0.5f);
        const float warp_z = depth_at(yarns.curves[warp], centre.x(), centre.y());
        const float weft_z = depth_at(yarns.curves[10 + weft], centre.x(), centre.y());
        EXPECT_EQ(warp_z > weft_z, fabric.weave().warp_over(warp, weft))
            << name << " " << warp << ", " << weft;
        // Peirce: touching, centres one section thickness apart.
        EXPECT_NEAR(std::abs(warp_z - weft_z), 2 * fabric.section().half_thickness_mm,
                    0.15f * fabric.section().half_thickness_mm);
      }
  }
}

TEST(WovenGeometry, SatinShowsOneThreadInFrontAndTheOtherBehind) {
  WovenFabric fabric = woven("satin-5.weave", 10, 10);
  YarnSet yarns;
  fabric.update(fabric.mesh(), yarns);
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

TEST(WovenGeometry, DensityInThreadsPerCentimetre) {
  auto plain = load_weave_matrix(test::shipped_pattern("plain.weave"));
  ASSERT_TRUE(plain);
  EXPECT_FLOAT_EQ(plain->gauge.ends_per_cm, 24);  // the shipped sheeting's
  EXPECT_FLOAT_EQ(plain->gauge.yarn_diameter_mm, 0.23f);
  plain->gauge = {};
  WovenParameters parameters;
  parameters.gauge = {30, 20, 0};
  auto built = WovenFabric::build(*plain, 12, 12, parameters);
  ASSERT_TRUE(built);
  WovenFabric& fabric = *built;
  const StitchMesh mesh = fabric.mesh();
  EXPECT_NEAR((mesh.vertex(10, 0) - mesh.vertex(0, 0)).norm(), 10 * 10.0f / 30, 1e-3f);
  EXPECT_NEAR((mesh.vertex(0, 10) - mesh.vertex(0, 0)).norm(), 10 * 10.0f / 20, 1e-3f);
  // The yarn that fills the spacing was derived, and said so.
  EXPECT_GT(fabric.dimensions().yarn_diameter_mm, 0.1f);
  EXPECT_FALSE(fabric.dimensions().notes.empty());
  parameters.gauge = {40, 40, 0.5f};  // a rope at 40 threads per cm
  const auto weave = load_weave_matrix(test::shipped_pattern("plain.weave"));
  const auto rope = WovenFabric::build(*weave, 4, 4, parameters);
  ASSERT_FALSE(rope);
  EXPECT_EQ(rope.error().key, "yarn_mm");
}

TEST(WovenGeometry, PlainWeaveIsCoveredByThread) {
  WovenFabric fabric = woven("plain.weave", 16, 16);
  YarnSet yarns;
  const StitchMesh mesh = fabric.mesh();
  fabric.update(mesh, yarns);
  const Eigen::Vector2d low = mesh.vertex(2, 2).head<2>().cast<double>();
  const Eigen::Vector2d high = mesh.vertex(14, 14).head<2>().cast<double>();
  EXPECT_GE(cover_factor(yarns, low, high - low, 0.005), 0.9);
  EXPECT_GE(fabric.dimensions().cover, 0.9);  // Peirce's, from the sizes
}

TEST(WovenGeometry, ThreadsNeverPassThroughEachOtherDeformed) {
  for (const char* name : {"plain.weave", "twill-2x2.weave", "satin-5.weave"}) {
    WovenFabric fabric = woven(name, 10, 10);
    for (const ClothDeformation deformation :
         {ClothDeformation{1, 0}, ClothDeformation{0.5f, 0}, ClothDeformation{2, 0},
          ClothDeformation{1, 0.5f}, ClothDeformation{0.75f, -0.25f}}) {
      YarnSet yarns;
      fabric.update(fabric.mesh(deformation), yarns);
      const YarnClearance clearance = min_clearance(yarns, fabric.section());
      EXPECT_GE(clearance.clearance, 0.95)
          << name << " stretch " << deformation.stretch << " shear " << deformation.shear;
    }
  }
}

TEST(KnitColours, ChartTiledWithItsColours) {
  const auto chart = load_stitch_chart(test::shipped_pattern("stripes.chart"));
  ASSERT_TRUE(chart) << chart.error().describe();
  auto fabric = KnitFabric::build(*chart, 7, 9, {});
  ASSERT_TRUE(fabric);
  YarnSet yarns;
  fabric->update(fabric->mesh(), yarns);
  ASSERT_EQ(yarns.curves.size(), 9U);
  for (int row = 0; row < 9; ++row) {
    const YarnCurve& course = yarns.curves[static_cast<std::size_t>(row)];
    ASSERT_EQ(course.colours.size(), course.points.size());
    for (const Eigen::Vector3f& colour : course.colours)
      EXPECT_EQ(colour, chart->palette[static_cast<std::size_t>(chart->colour_at(0, row))]);
  }
}

}  // namespace
}  // namespace psrig::cloth
