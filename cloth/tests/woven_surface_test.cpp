// The fabric surface model's geometry (chen2024 3.1) and the weaves made
// from rules: the yarn seen where the matrix says, heights worked out by
// hand, normals that agree with the height field, orientation and twist,
// and the yarns shadowing each other.
#include "psrig/cloth/woven_surface.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "psrig/cloth/weave_rules.h"
#include "test_support.h"

namespace psrig::cloth {
namespace {

WovenSurface surface_of(const WeaveMatrix& weave, YarnShape shape = {}, float beta = 1) {
  auto surface = WovenSurface::make(weave, shape, beta, beta);
  EXPECT_TRUE(surface) << surface.error().describe();
  return std::move(*surface);
}

WeaveMatrix shipped_weave(const char* name) {
  auto weave = load_weave_matrix(test::shipped_pattern(name));
  EXPECT_TRUE(weave) << weave.error().describe();
  return std::move(*weave);
}

std::vector<WeaveMatrix> every_weave() {
  std::vector<WeaveMatrix> weaves = chen2024_training_weaves();
  for (const char* name : {"plain.weave", "twill-2x2.weave", "satin-5.weave"})
    weaves.push_back(shipped_weave(name));
  weaves.push_back(twill_weave(3, 1));
  weaves.push_back(basket_weave(2));
  return weaves;
}

TEST(WeaveRules, RulesGiveTheShippedWeavesAndTheUnseenOnes) {
  const auto same = [](const WeaveMatrix& a, const WeaveMatrix& b) {
    return a.warps == b.warps && a.wefts == b.wefts && a.cells == b.cells;
  };
  EXPECT_TRUE(same(plain_weave(), shipped_weave("plain.weave")));
  EXPECT_TRUE(same(twill_weave(2, 2), shipped_weave("twill-2x2.weave")));
  EXPECT_TRUE(same(satin_weave(5, 2), shipped_weave("satin-5.weave")));
  // 3/1 twill: the warp floats over three wefts, under one, stepping on.
  const WeaveMatrix twill = twill_weave(3, 1);
  EXPECT_EQ(twill.cells,
            (std::vector<std::uint8_t>{1, 1, 1, 0, 0, 1, 1, 1, 1, 0, 1, 1, 1, 1, 0, 1}));
  // 2/2 basket: plain weave with doubled threads.
  const WeaveMatrix basket = basket_weave(2);
  EXPECT_EQ(basket.cells,
            (std::vector<std::uint8_t>{1, 1, 0, 0, 1, 1, 0, 0, 0, 0, 1, 1, 0, 0, 1, 1}));
  // chen2024's seven, by size.
  const std::vector<WeaveMatrix> seven = chen2024_training_weaves();
  ASSERT_EQ(seven.size(), 7U);
  const int sizes[7][2] = {{2, 2}, {3, 3}, {5, 5}, {8, 8}, {5, 5}, {8, 8}, {5, 10}};
  for (std::size_t k = 0; k < 7; ++k) {
    EXPECT_EQ(seven[k].warps, sizes[k][0]) << seven[k].name;
    EXPECT_EQ(seven[k].wefts, sizes[k][1]) << seven[k].name;
  }
  // A satin: one warp up on every weft, no two crossings side by side.
  for (const WeaveMatrix& satin : {seven[4], seven[5]})
    for (int weft = 0; weft < satin.wefts; ++weft) {
      int up = 0;
      for (int warp = 0; warp < satin.warps; ++warp)
        if (satin.warp_over(warp, weft)) {
          ++up;
          EXPECT_FALSE(satin.warp_over(warp + 1, weft + 1) || satin.warp_over(warp - 1, weft + 1))
              << satin.name;
        }
      EXPECT_EQ(up, 1) << satin.name;
    }
}

TEST(WovenSurface, TheYarnSeenIsTheOneTheMatrixPutsOnTopAndGapsAtTheCorners) {
  for (const WeaveMatrix& weave : every_weave()) {
    const WovenSurface surface = surface_of(weave);
    for (int weft = -1; weft <= weave.wefts; ++weft)
      for (int warp = -1; warp <= weave.warps; ++warp) {
        const Eigen::Vector2f crossing(warp + 0.5f, weft + 0.5f);
        EXPECT_EQ(surface.point(crossing).yarn,
                  weave.warp_over(warp, weft) ? YarnType::warp : YarnType::weft)
            << weave.name << " " << warp << ", " << weft;
        // Between wefts a warp shows, between warps a weft, at the corners
        // the gap (0.2 of a spacing, 0.1 each side of the edge).
        EXPECT_EQ(surface.point(crossing + Eigen::Vector2f(0, 0.47f)).yarn, YarnType::warp);
        EXPECT_EQ(surface.point(crossing + Eigen::Vector2f(0.47f, 0.1f)).yarn, YarnType::weft);
        EXPECT_EQ(surface.point(crossing + Eigen::Vector2f(0.45f, 0.45f)).yarn, YarnType::gap);
        const WovenPoint top = surface.point(crossing);
        EXPECT_GE(top.height, surface.floor_height());
        EXPECT_LE(top.height, surface.top_height() + 1e-6f);
      }
  }
}

// Plain weave at u = 30 degrees, gap 0.2, section edges at 60 degrees, by
// hand: a float is one crossing, half-chord a = 1/2, so its arc rises
// a tan(u / 2) = 0.5 tan 15 = 0.133975 at the crossing's centre; the
// section's radius is 0.4 / sin 60 = 0.461880 and it rises 0.461880 (1 -
// cos 60) = 0.230940 above its edges. The top of a float: 0.364915; the
// sinker's bottom (seen only through the gaps): -0.133975.
TEST(WovenSurface, HeightsAsWorkedByHand) {
  const WovenSurface plain = surface_of(plain_weave());
  EXPECT_NEAR(plain.point({0.5f, 0.5f}).height, 0.364915f, 1e-5f);
  EXPECT_NEAR(plain.top_height(), 0.364915f, 1e-5f);
  EXPECT_NEAR(plain.floor_height(), -0.133975f, 1e-5f);
  // beta scales heights.
  const WovenSurface doubled = surface_of(plain_weave(), {}, 2);
  EXPECT_NEAR(doubled.point({0.5f, 0.5f}).height, 2 * 0.364915f, 2e-5f);
  // A satin's float is four crossings long: it rises 2 tan 15 = 0.535898.
  const WovenSurface satin = surface_of(satin_weave(5, 2));
  // Weft 0 floats over warps 1..4 (warp 0 is up); its middle is x = 3.
  EXPECT_NEAR(satin.point({3.0f, 0.5f}).height, 0.535898f + 0.230940f, 1e-5f);
  // beta = 0: flat, normals straight up.
  const WovenSurface flat = surface_of(satin_weave(5, 2), {}, 0);
  EXPECT_FLOAT_EQ(flat.point({1.3f, 2.2f}).height, 0);
  EXPECT_NEAR(flat.point({1.3f, 2.2f}).normal.z(), 1, 1e-6f);
}

TEST(WovenSurface, NormalsAreTheHeightFieldsAndOrientationLiesInThePly) {
  YarnShape shape;
  shape.inclination_deg = 40;
  for (const WeaveMatrix& weave : every_weave())
    for (float beta : {0.5f, 1.0f, 2.0f}) {
      const WovenSurface surface = surface_of(weave, shape, beta);
      const float e = 1e-3f;
      for (int k = 0; k < 400; ++k) {
        // A grid of points over the repeat, kept off the yarns' edges where
        // the height field steps.
        const Eigen::Vector2f xy((k % 20 + 0.5f) / 20 * weave.warps,
                                 (k / 20 + 0.5f) / 20 * weave.wefts);
        const WovenPoint p = surface.point(xy);
        if (p.yarn == YarnType::gap) continue;
        bool same_yarn = true;
        for (const Eigen::Vector2f& d : {Eigen::Vector2f(e, 0), Eigen::Vector2f(-e, 0),
                                         Eigen::Vector2f(0, e), Eigen::Vector2f(0, -e)})
          same_yarn = same_yarn && surface.point(xy + d).yarn == p.yarn;
        // Cell edges (where a float's arc meets the next) are smooth, but
        // the yarn seen can change there; skip points next to any change.
        if (!same_yarn) continue;
        const float gx = (surface.height(xy + Eigen::Vector2f(e, 0)) -
                          surface.height(xy - Eigen::Vector2f(e, 0))) /
                         (2 * e);
        const float gy = (surface.height(xy + Eigen::Vector2f(0, e)) -
                          surface.height(xy - Eigen::Vector2f(0, e))) /
                         (2 * e);
        const Eigen::Vector3f expected = Eigen::Vector3f(-gx, -gy, 1).normalized();
        EXPECT_GT(p.normal.dot(expected), 0.9995f) << weave.name << " at " << xy.transpose();
        EXPECT_NEAR(p.normal.norm(), 1, 1e-5f);
        EXPECT_NEAR(p.orientation.norm(), 1, 1e-5f);
        EXPECT_NEAR(p.orientation.dot(p.normal), 0, 1e-5f);
      }
    }
}

TEST(WovenSurface, TwistTurnsThePlyFromTheYarnsAxis) {
  const WeaveMatrix satin = satin_weave(5, 2);
  for (float twist : {-30.0f, 0.0f, 30.0f}) {
    YarnShape shape;
    shape.twist_deg = twist;
    const WovenSurface surface = surface_of(satin, shape);
    // The top of the weft float over warps 1..4: flat there, axis along x.
    const WovenPoint top = surface.point({3.0f, 0.5f});
    ASSERT_EQ(top.yarn, YarnType::weft);
    const float angle =
        std::atan2(top.orientation.y(), top.orientation.x()) * 180 / std::numbers::pi_v<float>;
    EXPECT_NEAR(angle, twist, 1e-3f);
    // A warp, between wefts (warp 0 is up on weft 0): axis along y.
    const WovenPoint warp = surface.point({0.5f, 0.5f});
    ASSERT_EQ(warp.yarn, YarnType::warp);
    EXPECT_NEAR(std::abs(warp.orientation.dot(Eigen::Vector3f::UnitY())),
                std::cos(twist * std::numbers::pi_v<float> / 180), 0.02f);
  }
}

TEST(WovenSurface, YarnsShadowTheGapsAndTheSkyIsSeenFromTheTop) {
  const WovenSurface surface = surface_of(twill_weave(2, 2), {}, 1.5f);
  // From the top of a float everything above is seen.
  const Eigen::Vector2f float_top(1.5f, 1.0f);  // warp 1 over wefts 0 and 1: its apex
  ASSERT_EQ(surface.point(float_top).yarn, YarnType::warp);
  const Eigen::Vector3f top(float_top.x(), float_top.y(), surface.height(float_top));
  for (float angle : {0.0f, 30.0f, 60.0f, 80.0f})
    for (float turn : {0.0f, 90.0f, 180.0f, 270.0f}) {
      const float a = angle * std::numbers::pi_v<float> / 180,
                  t = turn * std::numbers::pi_v<float> / 180;
      const Eigen::Vector3f w(std::sin(a) * std::cos(t), std::sin(a) * std::sin(t), std::cos(a));
      EXPECT_TRUE(surface.visible(top + Eigen::Vector3f(0, 0, 1e-4f), w)) << angle << " " << turn;
    }
  // The floor in a gap: seen from straight above, hidden from a grazing
  // direction (the yarns around stand 0.3 spacings and more above it).
  const Eigen::Vector2f gap(1.0f, 1.0f);
  ASSERT_EQ(surface.point(gap).yarn, YarnType::gap);
  const Eigen::Vector3f floor(gap.x(), gap.y(), surface.floor_height());
  EXPECT_TRUE(surface.visible(floor, Eigen::Vector3f::UnitZ()));
  EXPECT_FALSE(surface.visible(floor, Eigen::Vector3f(1, 0, 0.1f).normalized()));
  // A ray from above meets the cloth where the height field is.
  const auto hit = surface.first_hit({0.3f, 0.2f, 5}, Eigen::Vector3f(0.2f, 0.1f, -1).normalized());
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->z(), surface.height(hit->head<2>()), 2e-3f);
}

TEST(WovenSurface, BadShapesAreBadInput) {
  YarnShape shape;
  shape.gap_ratio = 0.95f;
  EXPECT_FALSE(WovenSurface::make(plain_weave(), shape));
  shape = {};
  shape.inclination_deg = 0;
  EXPECT_FALSE(WovenSurface::make(plain_weave(), shape));
  EXPECT_FALSE(WovenSurface::make(plain_weave(), {}, -1, 1));
  EXPECT_FALSE(WovenSurface::make(WeaveMatrix{}, {}));
}

}  // namespace
}  // namespace psrig::cloth
