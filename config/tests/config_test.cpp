// rig.toml: the shipped files load clean, every mistake names its place.

#include <cmath>
#include <fstream>

#include <gtest/gtest.h>

#include "config_error.h"
#include "psrig/config/config_loader.h"
#include "test_support.h"

namespace psrig::config {
namespace {

namespace fs = std::filesystem;

fs::path config_dir() {
  return fs::path(PSRIG_SOURCE_DIR) / "config";
}

TEST(Config, ShippedFilesLoadWithoutWarnings) {
  for (const char* name : {"sim.toml", "rig.example.toml", "catalogue.example.toml"}) {
    std::vector<std::string> warnings;
    auto config = load_config(config_dir() / name, &warnings);
    ASSERT_TRUE(config) << name << ": " << config.error().describe();
    EXPECT_TRUE(warnings.empty()) << name << ": " << warnings.front();
  }
  auto sim = load_config(config_dir() / "sim.toml");
  EXPECT_EQ(sim->lights.backend, "sim");
  EXPECT_EQ(sim->camera.backend, "sim");
  EXPECT_EQ(sim->storage.root, (config_dir() / ".." / "out" / "scans").lexically_normal());
  EXPECT_EQ(sim->geometry.pixel_size_mm, 0.025);  // the simulator's
  auto example = load_config(config_dir() / "rig.example.toml");
  EXPECT_EQ(example->lights.gpiod.lines, (std::vector<unsigned>{17, 27, 22}));
  EXPECT_EQ(example->lights.modbus.parity, 'E');
  EXPECT_EQ(example->lights.usb.vendor_id, 0x1209);
}

TEST(Config, EmptyFileGivesTheDefaults) {
  auto config = parse_config("", "rig.toml");
  ASSERT_TRUE(config);
  EXPECT_EQ(config->lights.backend, "sim");
  EXPECT_EQ(config->geometry.tilts_deg, (std::vector<double>{0, 120, 240}));
  EXPECT_EQ(config->camera.frames_average, 2);
}

TEST(Config, MalformedTomlGivesLineAndColumn) {
  const auto e = expect_error("[lights]\nbackend = \"sim\"\nchannels = = 3\n", "", 3);
  EXPECT_GT(e.column, 0);
  EXPECT_NE(e.describe().find("/etc/psrig/rig.toml:3:"), std::string::npos) << e.describe();
}

TEST(Config, WrongTypeNamesTheKey) {
  const auto e = expect_error("[camera]\nexposure_us = \"fast\"\n", "camera.exposure_us", 2);
  EXPECT_EQ(e.column, 15);
  EXPECT_NE(
      e.describe().find("/etc/psrig/rig.toml:2:15: camera.exposure_us: expected a whole number"),
      std::string::npos)
      << e.describe();
}

TEST(Config, WebRootMustHoldTheBuiltCatalogue) {
  const auto e = expect_error("[daemon]\nweb_root = \"no-such-folder\"\n", "daemon.web_root", 2);
  EXPECT_NE(e.message.find("/etc/psrig/no-such-folder"), std::string::npos) << e.message;
  EXPECT_NE(e.message.find("scripts/build"), std::string::npos) << e.message;

  test::TempDir temp;
  std::ofstream(temp / "index.html") << "<!doctype html>";
  auto config = parse_config("[daemon]\nweb_root = \"" + temp.path().string() + "\"\n",
                             "/etc/psrig/rig.toml");
  ASSERT_TRUE(config) << config.error().describe();
  EXPECT_EQ(config->daemon.web_root, temp.path());
}

TEST(Config, OutOfRangeSaysWhatIsAllowed) {
  const auto e = expect_error("[geometry]\nslant_deg = 95\n", "geometry.slant_deg", 2);
  EXPECT_NE(e.message.find("95"), std::string::npos);
  EXPECT_NE(e.message.find("89"), std::string::npos);
}

TEST(Config, UnknownBackendListsTheChoices) {
  const auto e = expect_error("[lights]\nbackend = \"dmx\"\n", "lights.backend", 2);
  EXPECT_NE(e.message.find("\"gpiod\""), std::string::npos) << e.message;
}

TEST(Config, UnknownKeysAreWarnedNotRejected) {
  std::vector<std::string> warnings;
  auto config = parse_config("[camera]\nexposure_ms = 20\n[vendor]\ncolour = \"blue\"\n",
                             "rig.toml", &warnings);
  ASSERT_TRUE(config);
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_NE(warnings[0].find("rig.toml:2:1: camera.exposure_ms: unknown key, ignored (did you mean "
                             "'camera.exposure_us'?)"),
            std::string::npos)
      << warnings[0];
  EXPECT_NE(warnings[1].find("vendor"), std::string::npos);
}

TEST(Config, GpioLinesMustMatchTheChannels) {
  const auto e = expect_error("[lights]\nbackend = \"gpiod\"\n[lights.gpiod]\nlines = [17, 27]\n",
                              "lights.gpiod.lines", 4);
  EXPECT_NE(e.message.find("gpioinfo"), std::string::npos);
}

// Whole numbers are whole numbers: a float is refused, not converted (found
// by fuzzing: 1e308 was undefined behaviour), and a GPIO line beyond 32 bits
// is refused, not wrapped to another line.
TEST(Config, WholeNumbersAreNotConvertedFromFloatsOrWrapped) {
  expect_error("[lights]\nbackend = \"gpiod\"\n[lights.gpiod]\nlines = [1, 2, 1e308]\n",
               "lights.gpiod.lines", 4);
  expect_error("[lights]\nbackend = \"gpiod\"\n[lights.gpiod]\nlines = [4294967313, 18, 19]\n",
               "lights.gpiod.lines", 4);
  expect_error("[lights]\nchannels = 1e19\n", "lights.channels", 2);
  expect_error("[camera]\nexposure_us = 3.0\n", "camera.exposure_us", 2);
}

TEST(Config, TiltsMustMatchTheChannels) {
  expect_error("[geometry]\ntilts_deg = [0, 90]\n", "geometry.tilts_deg", 2);
  // More channels without tilts: spread evenly.
  auto four = parse_config("[lights]\nchannels = 4\n", "rig.toml");
  ASSERT_TRUE(four);
  EXPECT_EQ(four->geometry.tilts_deg, (std::vector<double>{0, 90, 180, 270}));
}

TEST(Config, NearFieldLedPositions) {
  // None: distant LEDs.
  auto plain = parse_config("", "rig.toml");
  ASSERT_TRUE(plain);
  EXPECT_TRUE(led_positions_mm(plain->geometry).empty());
  // Given one per light.
  auto given = parse_config(
      "[geometry]\nled_positions_mm = [[100, 0, 200], [-50, 86.6, 200], [-50, -86.6, 200.5]]\n",
      "rig.toml");
  ASSERT_TRUE(given) << given.error().describe();
  const auto p = led_positions_mm(given->geometry);
  ASSERT_EQ(p.size(), 3U);
  EXPECT_DOUBLE_EQ(p[2][2], 200.5);
  // Placed by a distance along slant and tilt.
  auto placed = parse_config("[geometry]\nslant_deg = 45\nled_distance_mm = 250\n", "rig.toml");
  ASSERT_TRUE(placed);
  const auto q = led_positions_mm(placed->geometry);
  ASSERT_EQ(q.size(), 3U);
  EXPECT_NEAR(q[0][0], 250 / std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(q[0][1], 0, 1e-9);
  EXPECT_NEAR(q[1][1], 250 / std::sqrt(2.0) * std::sin(120 * 3.14159265358979323846 / 180), 1e-9);
  EXPECT_NEAR(q[2][2], 250 / std::sqrt(2.0), 1e-9);
  // Errors name the key.
  expect_error("[geometry]\nled_positions_mm = [[1, 2, 3], [1, 2, 3]]\n",
               "geometry.led_positions_mm", 2);
  expect_error("[geometry]\nled_positions_mm = [[1, 2, 3], [1, 2], [1, 2, 3]]\n",
               "geometry.led_positions_mm", 2);
  expect_error("[geometry]\nled_positions_mm = [[1, 2, 3], [1, 2, -3], [1, 2, 3]]\n",
               "geometry.led_positions_mm", 2);
  expect_error("[geometry]\nled_positions_mm = \"near\"\n", "geometry.led_positions_mm", 2);
  expect_error("[geometry]\nled_distance_mm = 0\n", "geometry.led_distance_mm", 2);
  expect_error(
      "[geometry]\nled_positions_mm = [[1, 2, 3], [1, 2, 3], [1, 2, 3]]\nled_distance_mm = 200\n",
      "geometry.led_distance_mm", 3);
}

TEST(Config, SimSpherePlacement) {
  auto placed = parse_config("[sim]\nsphere_centre_mm = [4, -2.5]\n", "rig.toml");
  ASSERT_TRUE(placed) << placed.error().describe();
  ASSERT_TRUE(placed->sim.sphere_centre_mm);
  EXPECT_EQ((*placed->sim.sphere_centre_mm)[1], -2.5);
  EXPECT_FALSE(parse_config("", "rig.toml")->sim.sphere_centre_mm);
  expect_error("[sim]\nsphere_centre_mm = [4]\n", "sim.sphere_centre_mm", 2);
  expect_error("[sim]\nsphere_centre_mm = \"middle\"\n", "sim.sphere_centre_mm", 2);
}

// [sim] pattern: a shipped name is kept as given (the simulator finds it);
// a chart or weave file is found from the rig.toml's folder and must exist;
// patterns_dir likewise.
TEST(Config, SimPatternIsANameOrAFileBesideTheRigToml) {
  EXPECT_EQ(parse_config("", "rig.toml")->sim.pattern, "jersey");
  auto named = parse_config("[sim]\npattern = \"rib-2x2\"\n", "/etc/psrig/rig.toml");
  ASSERT_TRUE(named) << named.error().describe();
  EXPECT_EQ(named->sim.pattern, "rib-2x2");

  test::TempDir temp;
  fs::create_directories(temp / "patterns");
  std::ofstream(temp / "patterns" / "moss.chart") << "K P\nP K\n";
  const fs::path rig = temp / "rig.toml";
  auto file =
      parse_config("[sim]\npattern = \"patterns/moss.chart\"\npatterns_dir = \"patterns\"\n", rig);
  ASSERT_TRUE(file) << file.error().describe();
  EXPECT_EQ(fs::path(file->sim.pattern), temp / "patterns" / "moss.chart");
  EXPECT_EQ(file->sim.patterns_dir, temp / "patterns");

  const auto missing = expect_error("[sim]\npattern = \"argyle.chart\"\n", "sim.pattern", 2);
  EXPECT_NE(missing.message.find("/etc/psrig/argyle.chart"), std::string::npos) << missing.message;
  EXPECT_NE(missing.message.find("stockinette"), std::string::npos) << missing.message;
  expect_error("[sim]\npattern = \"\"\n", "sim.pattern", 2);
  const auto folder = expect_error("[sim]\npatterns_dir = \"nowhere\"\n", "sim.patterns_dir", 2);
  EXPECT_NE(folder.message.find("/etc/psrig/nowhere"), std::string::npos) << folder.message;
}

TEST(Config, ModbusParityAndRegisterMap) {
  auto config = parse_config(
      "[lights.modbus]\nparity = \"O\"\n[lights.modbus.registers]\nenable_coil = "
      "16\nintensity_full_scale = 4095\n",
      "rig.toml");
  ASSERT_TRUE(config) << config.error().describe();
  EXPECT_EQ(config->lights.modbus.parity, 'O');
  EXPECT_EQ(config->lights.modbus.registers.enable_coil, 16);
  EXPECT_EQ(config->lights.modbus.registers.intensity_full_scale, 4095);
  expect_error("[lights.modbus]\nparity = \"X\"\n", "lights.modbus.parity", 2);
}

TEST(Config, ModbusAllOffCoilAndDeviceId) {
  auto config = parse_config(
      "[lights.modbus.registers]\nall_off_coil = -1\nid_register = 7\ndevice_id = 0x1234\n",
      "rig.toml");
  ASSERT_TRUE(config) << config.error().describe();
  EXPECT_EQ(config->lights.modbus.registers.all_off_coil, -1);
  EXPECT_EQ(config->lights.modbus.registers.id_register, 7);
  EXPECT_EQ(config->lights.modbus.registers.device_id, 0x1234);
  expect_error("[lights.modbus.registers]\nall_off_coil = -2\n",
               "lights.modbus.registers.all_off_coil", 2);
  expect_error("[lights.modbus.registers]\ndevice_id = 65536\n",
               "lights.modbus.registers.device_id", 2);
}

TEST(Config, SectionThatIsNotATable) {
  expect_error("camera = \"v4l2\"\n", "camera", 1);
}

TEST(Config, MissingFile) {
  auto config = load_config("/nonexistent/rig.toml");
  ASSERT_FALSE(config);
  EXPECT_NE(config.error().describe().find("/nonexistent/rig.toml"), std::string::npos);
}

}  // namespace
}  // namespace psrig::config
