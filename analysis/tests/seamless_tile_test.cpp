// The seamless tile: whole repeats, no visible seam when repeated 2x2 (the
// second difference across the join no larger than the tile's own 95th
// percentile line), the same repeat measured on the 2x2, the physical size
// kept; a non-periodic input gives the whole scan with a blended border.

#include "psrig/analysis/seamless_tile.h"

#include <cmath>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "psrig/analysis/fabric_measure.h"
#include "psrig/sim/swatch_model.h"
#include "shipped_swatch.h"

namespace psrig::processing {
namespace {

struct TileCase {
  const char* pattern;
  double rotation_deg;
};

formats::Maps maps_of(const TileCase& c) {
  sim::SwatchParams params = test::swatch_params(c.pattern, {640, 480}, 0.025, 5);
  params.rotation_deg = c.rotation_deg;
  const sim::Swatch swatch = test::made(sim::make_swatch(params));
  formats::Maps maps;
  maps.albedo = swatch.albedo;
  maps.height = swatch.height_mm;
  maps.pixel_size_mm = 0.025;
  maps.height_units = "mm";
  cv::Mat n[3];
  cv::split(swatch.normal, n);
  maps.p = -n[0] / n[2];
  maps.q = -n[1] / n[2];
  maps.mask = cv::Mat(swatch.albedo.size(), CV_8U, cv::Scalar(255));
  return maps;
}

class SeamlessTile : public ::testing::TestWithParam<TileCase> {};

TEST_P(SeamlessTile, RepeatsWithoutSeamAndKeepsItsPeriodAndSize) {
  const formats::Maps maps = maps_of(GetParam());
  const auto lattice = analysis::find_repeat_lattice(maps.height, maps.albedo);
  ASSERT_TRUE(lattice);
  const auto tile = analysis::make_seamless_tile(maps, lattice);
  ASSERT_TRUE(tile) << tile.error().describe();
  ASSERT_TRUE(tile->periodic);
  EXPECT_GE(tile->repeats_u, 2);
  EXPECT_GE(tile->repeats_v, 2);
  // The seam check, on the height and on the albedo.
  EXPECT_TRUE(tile->seam.passed()) << tile->seam.value << " > " << tile->seam.bound;
  cv::Mat grey;
  cv::transform(tile->maps.albedo, grey, cv::Matx<float, 1, 3>(1.0f / 3, 1.0f / 3, 1.0f / 3));
  const analysis::SeamCheck albedo = analysis::check_seam(grey, "albedo");
  EXPECT_TRUE(albedo.passed()) << albedo.value << " > " << albedo.bound;
  // The repeat measured on the 2x2 is the tile's: width / nu across, height / nv up.
  cv::Mat h2, a2;
  cv::repeat(tile->maps.height, 2, 2, h2);
  cv::repeat(tile->maps.albedo, 2, 2, a2);
  const auto again = analysis::find_repeat_lattice(h2, a2);
  ASSERT_TRUE(again);
  const double period_u = static_cast<double>(tile->maps.p.cols) / tile->repeats_u;
  const double period_v = static_cast<double>(tile->maps.p.rows) / tile->repeats_v;
  EXPECT_NEAR(again->u_px.x / period_u, 1.0, 0.005);
  EXPECT_NEAR(again->v_px.y / period_v, 1.0, 0.005);
  EXPECT_NEAR(again->u_px.y, 0.0, 0.3);  // deskewed: along the tile's axes
  EXPECT_NEAR(again->v_px.x, 0.0, 0.3);
  // Physical size: whole repeats of the fabric's own.
  const double repeat_mm = std::hypot(lattice->u_px.x, lattice->u_px.y) * 0.025;
  EXPECT_NEAR(tile->width / (tile->repeats_u * repeat_mm), 1.0, 1e-9);
  EXPECT_NEAR(*tile->pixel_size_mm * tile->maps.p.cols / tile->width, 1.0, 1e-9);
  EXPECT_NEAR(*tile->pixel_size_mm * tile->maps.p.rows / tile->height, 1.0, 0.003);
  const nlohmann::json j = analysis::tile_json(*tile);
  EXPECT_EQ(j["format"], formats::tile_files::kFormat);
  EXPECT_EQ(j["repeats"][0], tile->repeats_u);
  EXPECT_TRUE(j["seam"]["passed"].get<bool>());
}

INSTANTIATE_TEST_SUITE_P(Patterns, SeamlessTile,
                         ::testing::Values(TileCase{"jersey", 0}, TileCase{"rib", 0},
                                           TileCase{"garter", 0}, TileCase{"plain", 0},
                                           TileCase{"twill", 0}, TileCase{"jersey", -3},
                                           TileCase{"rib", 4}, TileCase{"garter", -2.5},
                                           TileCase{"plain", 3}, TileCase{"twill", -4}),
                         [](const ::testing::TestParamInfo<TileCase>& param_info) {
                           const double r = param_info.param.rotation_deg;
                           return std::string(param_info.param.pattern) + (r == 0  ? ""
                                                                           : r > 0 ? "_turned_ccw"
                                                                                   : "_turned_cw");
                         });

TEST(SeamlessTileCheck, AHardSeamFails) {
  // A ramp repeated has a cliff at its join: the check must see it.
  cv::Mat ramp(64, 64, CV_32F);
  for (int r = 0; r < 64; ++r)
    for (int c = 0; c < 64; ++c)
      ramp.at<float>(r, c) = 0.1f * c + 0.05f * std::sin(r * 0.7f);
  EXPECT_FALSE(analysis::check_seam(ramp, "height").passed());
}

TEST(SeamlessTileCheck, NonPeriodicInputGivesTheWholeScanWithABlendedBorder) {
  formats::Maps maps;
  cv::Mat height(300, 400, CV_32F);
  cv::RNG rng(11);
  rng.fill(height, cv::RNG::NORMAL, 0, 1);
  cv::GaussianBlur(height, height, {0, 0}, 5);
  maps.height = height;
  maps.albedo = cv::Mat(height.size(), CV_32FC3, cv::Scalar::all(0.5));
  cv::Sobel(height, maps.p, CV_32F, 1, 0, 1, 0.5);
  cv::Sobel(height, maps.q, CV_32F, 0, 1, 1, -0.5);
  maps.mask = cv::Mat(height.size(), CV_8U, cv::Scalar(255));
  std::string why;
  const auto lattice = analysis::find_repeat_lattice(maps.height, maps.albedo, &why);
  ASSERT_FALSE(lattice);
  EXPECT_NE(why.find("no repeat found"), std::string::npos) << why;
  const auto tile = analysis::make_seamless_tile(maps, lattice);
  ASSERT_TRUE(tile) << tile.error().describe();
  EXPECT_FALSE(tile->periodic);
  EXPECT_NE(tile->message.find("whole scan"), std::string::npos) << tile->message;
  EXPECT_EQ(tile->maps.p.cols, 400 - tile->band_px);
  EXPECT_EQ(tile->maps.p.rows, 300 - tile->band_px);
  EXPECT_TRUE(tile->seam.passed()) << tile->seam.value << " > " << tile->seam.bound;
  EXPECT_FALSE(tile->pixel_size_mm);
  EXPECT_EQ(analysis::tile_json(*tile)["units"], "px");
}

TEST(SeamlessTileCheck, TooManyRepeatsIsBadInput) {
  const formats::Maps maps = maps_of({"jersey", 0});
  const auto lattice = analysis::find_repeat_lattice(maps.height, maps.albedo);
  ASSERT_TRUE(lattice);
  const auto tile = analysis::make_seamless_tile(maps, lattice, {.repeats = 40});
  ASSERT_FALSE(tile);
  EXPECT_EQ(tile.error().kind, ErrorKind::bad_input);
  EXPECT_NE(tile.error().describe().find("--repeats"), std::string::npos);
  const auto two = analysis::make_seamless_tile(maps, lattice, {.repeats = 2});
  ASSERT_TRUE(two);
  EXPECT_EQ(two->repeats_u, 2);
  EXPECT_EQ(two->repeats_v, 2);
}

}  // namespace
}  // namespace psrig::processing
