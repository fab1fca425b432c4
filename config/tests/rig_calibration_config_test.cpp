// rig.toml's calibration and processing keys: [calibration] max_age_days
// and sphere_diameter_mm, [processing] reject, [camera] principal_point_px,
// [geometry] swatch_height_mm, [sim] card_albedo, sphere_places_mm,
// led_distance_mm; and "flat" read as the grey card.

#include <gtest/gtest.h>

#include "config_error.h"
#include "psrig/config/config_loader.h"

namespace psrig::config {
namespace {

TEST(RigCalibrationConfig, Defaults) {
  auto c = parse_config("", "rig.toml");
  ASSERT_TRUE(c);
  EXPECT_EQ(c->calibration.max_age_days, 30);
  EXPECT_FALSE(c->calibration.sphere_diameter_mm);
  EXPECT_FALSE(c->processing.reject);
  EXPECT_FALSE(c->camera.principal_point_px);
  EXPECT_EQ(c->geometry.swatch_height_mm, 0);
  EXPECT_EQ(c->sim.card_albedo, 0.75);
  EXPECT_TRUE(c->sim.sphere_places_mm.empty());
  EXPECT_FALSE(c->sim.led_distance_mm);
}

TEST(RigCalibrationConfig, KeysRead) {
  std::vector<std::string> warnings;
  auto c = parse_config(
      "[geometry]\nswatch_height_mm = 2.5\n[camera]\nprincipal_point_px = [320.5, 240]\n"
      "[processing]\nreject = true\n[calibration]\nmax_age_days = 0\nsphere_diameter_mm = 6.35\n"
      "[sim]\ntarget = \"white_card\"\ncard_albedo = 0.5\nsphere_places_mm = [[-8, 5], [8, 5], "
      "[0, -7]]\nled_distance_mm = 250\n",
      "rig.toml", &warnings);
  ASSERT_TRUE(c) << c.error().describe();
  EXPECT_TRUE(warnings.empty()) << warnings.front();
  EXPECT_EQ(c->geometry.swatch_height_mm, 2.5);
  EXPECT_EQ(*c->camera.principal_point_px, (std::array<double, 2>{320.5, 240}));
  EXPECT_TRUE(c->processing.reject);
  EXPECT_EQ(c->calibration.max_age_days, 0);
  EXPECT_EQ(*c->calibration.sphere_diameter_mm, 6.35);
  EXPECT_EQ(c->sim.card_albedo, 0.5);
  ASSERT_EQ(c->sim.sphere_places_mm.size(), 3u);
  EXPECT_EQ(c->sim.sphere_places_mm[2], (std::array<double, 2>{0, -7}));
  EXPECT_EQ(*c->sim.led_distance_mm, 250);
}

TEST(RigCalibrationConfig, FlatIsTheGreyCard) {
  auto c = parse_config("[sim]\ntarget = \"flat\"\n", "rig.toml");
  ASSERT_TRUE(c);
  EXPECT_EQ(c->sim.target, "white_card");
  EXPECT_EQ(c->sim.card_albedo, 0.6);
}

TEST(RigCalibrationConfig, MistakesNameTheirPlace) {
  auto e = expect_error("[calibration]\nmax_age_days = -1\n", "calibration.max_age_days", 2);
  EXPECT_NE(e.message.find("expected 0 to"), std::string::npos) << e.message;
  expect_error("[calibration]\nmax_age_days = 1.5\n", "calibration.max_age_days", 2);
  expect_error("[calibration]\nsphere_diameter_mm = 0\n", "calibration.sphere_diameter_mm", 2);
  expect_error("[processing]\nreject = \"yes\"\n", "processing.reject", 2);
  expect_error("[camera]\nprincipal_point_px = [1, 2, 3]\n", "camera.principal_point_px", 2);
  expect_error("[geometry]\nswatch_height_mm = -1\n", "geometry.swatch_height_mm", 2);
  expect_error("[sim]\ncard_albedo = 1.5\n", "sim.card_albedo", 2);
  expect_error("[sim]\nsphere_places_mm = [[1, 2], [3]]\n", "sim.sphere_places_mm", 2);
  expect_error("[sim]\nled_distance_mm = 0\n", "sim.led_distance_mm", 2);
}

// [storage]'s compression keys: the defaults, the values read, bad ones
// refused naming the key and line.
TEST(RigCalibrationConfig, StorageCompression) {
  auto defaults = parse_config("", "rig.toml");
  ASSERT_TRUE(defaults);
  EXPECT_EQ(defaults->storage.exr_compression, "auto");
  EXPECT_EQ(defaults->storage.png_level, 1);
  EXPECT_EQ(defaults->storage.map_precision, "half");
  auto c = parse_config(
      "[storage]\nexr_compression = \"piz\"\npng_level = 6\nmap_precision = \"float\"\n",
      "rig.toml");
  ASSERT_TRUE(c) << c.error().describe();
  EXPECT_EQ(c->storage.exr_compression, "piz");
  EXPECT_EQ(c->storage.png_level, 6);
  EXPECT_EQ(c->storage.map_precision, "float");
  expect_error("[storage]\nmap_precision = \"double\"\n", "storage.map_precision", 2);
  expect_error("[storage]\nexr_compression = \"dwab\"\n", "storage.exr_compression", 2);
  expect_error("[storage]\npng_level = 10\n", "storage.png_level", 2);
}

}  // namespace
}  // namespace psrig::config
