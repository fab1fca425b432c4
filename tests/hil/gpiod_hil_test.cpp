// The gpiod light backend, the real libgpiod 1.6 underneath, against a GPIO
// chip emulated in user space (run under umockdev-wrapper; skipped without).
// What the backend says it did (its switch log) is checked against what the
// chip saw on its lines (its own history), through the LED wiring.

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "emulated_gpio_chip.h"
#include "gpio_led_wiring.h"
#include "psrig/lights/gpiod_lights.h"
#include "psrig/lights/light_controller.h"
#include "psrig/lights/safe_lights.h"
#include "psrig/rig/open_devices.h"
#include "psrig/sim/simulated_leds.h"
#include "umockdev_bed.h"

namespace psrig::test {
namespace {

using lights::LightController;
using lights::SafeLights;
using namespace std::chrono_literals;

const std::vector<unsigned> kLines{17, 27, 22};
constexpr unsigned kChipLines = 32;

config::LightsConfig gpiod_config(const std::string& chip, bool active_low = false) {
  config::LightsConfig lights;
  lights.backend = "gpiod";
  lights.channels = 3;
  lights.gpiod.chip = chip;
  lights.gpiod.lines = kLines;
  lights.gpiod.active_low = active_low;
  lights.gpiod.consumer = "psrig-hil";
  return lights;
}

// Every line at `rest`, the LED lines at `lit` where listed.
std::vector<int> levels_with(int rest, const std::vector<unsigned>& at, int level) {
  std::vector<int> levels(kChipLines, rest);
  for (unsigned offset : at)
    levels[offset] = level;
  return levels;
}

class GpiodLights : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!UmockdevBed::available()) GTEST_SKIP() << "not under umockdev-wrapper";
    bed_ = std::make_unique<UmockdevBed>();
  }
  // Chips go before the bed they live in.
  void TearDown() override {
    chips_.clear();
    bed_.reset();
  }

  EmulatedGpioChip& add_chip(const std::string& name, const std::string& label, unsigned minor,
                             int initial_level = 0) {
    EmulatedGpioChip::Options options;
    options.name = name;
    options.label = label;
    options.lines = kChipLines;
    options.minor = minor;
    options.initial_level = initial_level;
    chips_.push_back(std::make_unique<EmulatedGpioChip>(*bed_, options));
    return *chips_.back();
  }

  std::unique_ptr<UmockdevBed> bed_;
  std::vector<std::unique_ptr<EmulatedGpioChip>> chips_;
};

std::unique_ptr<LightController> open_or_fail(const config::LightsConfig& config) {
  auto lights = lights::open_gpiod_lights(config);
  if (!lights) ADD_FAILURE() << lights.error().describe();
  return lights ? std::move(*lights) : nullptr;
}

TEST_F(GpiodLights, OpensByPathWithEveryLedOff) {
  auto& chip = add_chip("gpiochip0", "psrig-leds", 0, /*initial_level=*/1);
  auto lights = open_or_fail(gpiod_config("/dev/gpiochip0"));
  ASSERT_TRUE(lights);
  EXPECT_EQ(lights->channel_count(), 3);
  EXPECT_EQ(chip.requested(), (std::set<unsigned>{17, 22, 27}));
  for (unsigned offset : kLines) {
    EXPECT_EQ(chip.consumer(offset), "psrig-hil") << "line " << offset;
    EXPECT_EQ(chip.request_flags(offset), GPIOHANDLE_REQUEST_OUTPUT) << "line " << offset;
  }
  // Requested low at once (the lines idled high), the others untouched.
  EXPECT_EQ(chip.levels(), levels_with(1, kLines, 0));
  EXPECT_EQ(lights->log().on_now(), std::vector<int>{});
  EXPECT_NE(lights->describe().find("gpiochip0 [psrig-leds]"), std::string::npos)
      << lights->describe();
}

TEST_F(GpiodLights, EachChannelDrivesExactlyItsLine) {
  auto& chip = add_chip("gpiochip0", "psrig-leds", 0);
  auto lights = open_or_fail(gpiod_config("/dev/gpiochip0"));
  ASSERT_TRUE(lights);
  const GpioLedWiring wiring{kLines, false};
  for (int channel : {0, 1, 2, 1, 0, 2}) {
    ASSERT_TRUE(lights->all_off());
    EXPECT_EQ(chip.levels(), levels_with(0, {}, 0));
    ASSERT_TRUE(lights->turn_on(channel));
    EXPECT_EQ(chip.levels(), levels_with(0, {kLines[channel]}, 1)) << "channel " << channel;
    EXPECT_EQ(wiring.lit_channels(chip.levels()), std::vector<int>{channel});
    EXPECT_EQ(lights->log().on_now(), std::vector<int>{channel});
  }
  ASSERT_TRUE(lights->all_off());
  EXPECT_EQ(chip.levels(), levels_with(0, {}, 0));
  EXPECT_TRUE(chip.requests_seen().contains(GPIOHANDLE_SET_LINE_VALUES_IOCTL));
}

TEST_F(GpiodLights, ActiveLowLightsAnLedByDrivingItsLineLow) {
  auto& chip = add_chip("gpiochip0", "psrig-leds", 0, /*initial_level=*/0);
  auto lights = open_or_fail(gpiod_config("/dev/gpiochip0", /*active_low=*/true));
  ASSERT_TRUE(lights);
  for (unsigned offset : kLines)
    EXPECT_EQ(chip.request_flags(offset),
              GPIOHANDLE_REQUEST_OUTPUT | GPIOHANDLE_REQUEST_ACTIVE_LOW);
  // Off is high: the lines that idled low went high at the request.
  EXPECT_EQ(chip.levels(), levels_with(0, kLines, 1));
  const GpioLedWiring wiring{kLines, true};
  EXPECT_EQ(wiring.lit_channels(chip.levels()), std::vector<int>{});
  ASSERT_TRUE(lights->turn_on(2));
  EXPECT_EQ(chip.levels(), levels_with(0, {17, 27}, 1));
  EXPECT_EQ(wiring.lit_channels(chip.levels()), std::vector<int>{2});
  ASSERT_TRUE(lights->all_off());
  EXPECT_EQ(chip.levels(), levels_with(0, kLines, 1));
}

TEST_F(GpiodLights, OpensByLabelNameOrNumberAmongSeveralChips) {
  auto& other = add_chip("gpiochip0", "pinctrl-bcm2711", 0);
  auto& leds = add_chip("gpiochip1", "psrig-leds", 1);
  for (const std::string spec : {"psrig-leds", "gpiochip1", "1", "/dev/gpiochip1"}) {
    auto lights = open_or_fail(gpiod_config(spec));
    ASSERT_TRUE(lights) << spec;
    EXPECT_EQ(leds.requested(), (std::set<unsigned>{17, 22, 27})) << spec;
    EXPECT_EQ(other.requested(), std::set<unsigned>{}) << spec;
    ASSERT_TRUE(lights->turn_on(1));
    EXPECT_EQ(leds.levels(), levels_with(0, {27}, 1)) << spec;
    EXPECT_EQ(other.levels(), levels_with(0, {}, 0)) << spec;
  }
}

TEST_F(GpiodLights, ClosingSwitchesEveryLedOffAndFreesTheLines) {
  auto& chip = add_chip("gpiochip0", "psrig-leds", 0);
  auto lights = open_or_fail(gpiod_config("gpiochip0"));
  ASSERT_TRUE(lights);
  ASSERT_TRUE(lights->turn_on(0));
  EXPECT_EQ(chip.levels(), levels_with(0, {17}, 1));
  lights.reset();
  EXPECT_EQ(chip.levels(), levels_with(0, {}, 0));
  EXPECT_EQ(chip.requested(), std::set<unsigned>{});
  // Freed for real: a second backend gets them.
  auto again = open_or_fail(gpiod_config("gpiochip0"));
  EXPECT_TRUE(again);
}

// The rig's first promise, seen from both ends: the backend's switch log
// and the levels the chip was set to, read through the wiring.
TEST_F(GpiodLights, NeverTwoLedsLitInTheLogOrOnTheLines) {
  // Pulled up, so the active-low LEDs are dark before anyone drives them.
  auto& chip = add_chip("gpiochip0", "psrig-leds", 0, /*initial_level=*/1);
  auto backend = open_or_fail(gpiod_config("gpiochip0", /*active_low=*/true));
  ASSERT_TRUE(backend);
  const auto* backend_log = &backend->log();
  SafeLights lights(std::move(backend), 5s);
  for (int round = 0; round < 5; ++round)
    for (int channel = 0; channel < 3; ++channel)
      ASSERT_TRUE(lights.turn_on(channel));
  ASSERT_TRUE(lights.all_off());

  const GpioLedWiring wiring{kLines, true};
  const auto history = chip.history();
  EXPECT_EQ(backend_log->overlap(), std::nullopt) << *backend_log->overlap();
  EXPECT_EQ(wiring.most_lit(history), 1);
  int lit_entries = 0;
  for (const auto& levels : history)
    lit_entries += wiring.lit_channels(levels).size() == 1;
  EXPECT_EQ(lit_entries, 15);
}

TEST_F(GpiodLights, SwitchingFromOneLedToAnotherPassesThroughDark) {
  auto& chip = add_chip("gpiochip0", "psrig-leds", 0);
  auto lights = open_or_fail(gpiod_config("gpiochip0"));
  ASSERT_TRUE(lights);
  ASSERT_TRUE(lights->turn_on(0));
  // Not what callers should do (SafeLights switches off first), but a
  // backend that swapped the two lines in one write would light both on a
  // driver that sets lines one by one.
  ASSERT_TRUE(lights->turn_on(1));
  const GpioLedWiring wiring{kLines, false};
  const auto history = chip.history();
  EXPECT_EQ(wiring.most_lit(history), 1);
  ASSERT_GE(history.size(), 3u);
  EXPECT_EQ(wiring.lit_channels(history[history.size() - 2]), std::vector<int>{});
  EXPECT_EQ(wiring.lit_channels(history.back()), std::vector<int>{1});
  EXPECT_EQ(lights->log().overlap(), std::nullopt);
}

TEST_F(GpiodLights, LinesLightTheSimulatedWorld) {
  auto& chip = add_chip("gpiochip0", "psrig-leds", 0, 1);
  config::RigConfig rig;
  rig.sim.width = 32;
  rig.sim.height = 24;
  auto leds = sim::SimulatedLeds::attach(rig);
  const GpioLedWiring wiring{kLines, true};
  wiring.connect(chip, GpioLedWiring::to_leds(leds));
  auto lights = open_or_fail(gpiod_config("gpiochip0", true));
  ASSERT_TRUE(lights);
  EXPECT_EQ(leds->leds_on(), std::vector<int>{});
  for (int channel : {2, 0, 1}) {
    ASSERT_TRUE(lights->all_off());
    ASSERT_TRUE(lights->turn_on(channel));
    EXPECT_EQ(leds->leds_on(), std::vector<int>{channel});
  }
  ASSERT_TRUE(lights->all_off());
  EXPECT_EQ(leds->leds_on(), std::vector<int>{});
  EXPECT_EQ(leds->log().overlap(), std::nullopt);
}

TEST_F(GpiodLights, DimmingIsRefusedAndZeroIntensityKeepsTheChannelDark) {
  auto& chip = add_chip("gpiochip0", "psrig-leds", 0);
  auto config = gpiod_config("gpiochip0");
  config.intensity = {1.0, 0.5, 1.0};
  auto refused = lights::open_gpiod_lights(config);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().key, "lights.intensity[1]");
  EXPECT_EQ(chip.requested(), std::set<unsigned>{});

  config.intensity = {1.0, 0.0, 1.0};
  auto lights = open_or_fail(config);
  ASSERT_TRUE(lights);
  ASSERT_TRUE(lights->turn_on(1));
  EXPECT_EQ(chip.levels(), levels_with(0, {}, 0));
  EXPECT_EQ(lights->log().on_now(), std::vector<int>{});
  EXPECT_FALSE(lights->set_intensity(0, 0.25));
  ASSERT_TRUE(lights->set_intensity(1, 1.0));
  ASSERT_TRUE(lights->turn_on(1));
  EXPECT_EQ(chip.levels(), levels_with(0, {27}, 1));
}

// Errors name what is wrong (chip, line, configuration key) and what exists.
TEST_F(GpiodLights, UnknownChipPathNamesItAndTheChipsThatExist) {
  add_chip("gpiochip0", "psrig-leds", 0);
  auto lights = lights::open_gpiod_lights(gpiod_config("/dev/gpiochip7"));
  ASSERT_FALSE(lights);
  const auto& error = lights.error();
  EXPECT_EQ(error.key, "lights.gpiod.chip");
  EXPECT_NE(error.message.find("/dev/gpiochip7"), std::string::npos) << error.message;
  EXPECT_NE(error.message.find("gpiochip0 [psrig-leds] 32 lines"), std::string::npos)
      << error.message;
}

TEST_F(GpiodLights, UnknownLabelNamesItAndTheLabelsThatExist) {
  add_chip("gpiochip0", "pinctrl-bcm2711", 0);
  add_chip("gpiochip1", "psrig-leds", 1);
  auto lights = lights::open_gpiod_lights(gpiod_config("psrig-ledz"));
  ASSERT_FALSE(lights);
  const auto& error = lights.error();
  EXPECT_EQ(error.key, "lights.gpiod.chip");
  EXPECT_NE(error.message.find("'psrig-ledz'"), std::string::npos) << error.message;
  EXPECT_NE(error.message.find("gpiochip0 [pinctrl-bcm2711]"), std::string::npos) << error.message;
  EXPECT_NE(error.message.find("gpiochip1 [psrig-leds]"), std::string::npos) << error.message;
}

TEST_F(GpiodLights, NotAGpioChipIsSaidSo) {
  add_chip("gpiochip0", "psrig-leds", 0);
  auto lights = lights::open_gpiod_lights(gpiod_config("/dev/null"));
  ASSERT_FALSE(lights);
  EXPECT_EQ(lights.error().key, "lights.gpiod.chip");
  EXPECT_NE(lights.error().message.find("not a GPIO character device"), std::string::npos)
      << lights.error().message;
}

TEST_F(GpiodLights, OffsetBeyondTheChipNamesLineChipAndKey) {
  auto& chip = add_chip("gpiochip0", "psrig-leds", 0);
  auto config = gpiod_config("gpiochip0");
  config.gpiod.lines = {17, 40, 22};
  auto lights = lights::open_gpiod_lights(config);
  ASSERT_FALSE(lights);
  const auto& error = lights.error();
  EXPECT_EQ(error.key, "lights.gpiod.lines[1]");
  EXPECT_NE(error.message.find("line 40"), std::string::npos) << error.message;
  EXPECT_NE(error.message.find("gpiochip0 [psrig-leds] has 32 lines"), std::string::npos)
      << error.message;
  EXPECT_EQ(chip.requested(), std::set<unsigned>{});
}

TEST_F(GpiodLights, LineHeldBySomeoneElseNamesTheHolder) {
  auto& chip = add_chip("gpiochip0", "psrig-leds", 0);
  chip.hold(27, "spi0 CS1");
  auto lights = lights::open_gpiod_lights(gpiod_config("gpiochip0"));
  ASSERT_FALSE(lights);
  const auto& error = lights.error();
  EXPECT_EQ(error.key, "lights.gpiod.lines[1]");
  EXPECT_NE(error.message.find("line 27 of gpiochip0"), std::string::npos) << error.message;
  EXPECT_NE(error.message.find("'spi0 CS1'"), std::string::npos) << error.message;
  EXPECT_EQ(chip.requested(), std::set<unsigned>{});
}

TEST_F(GpiodLights, SecondPsrigOnTheSameLinesIsToldWhy) {
  add_chip("gpiochip0", "psrig-leds", 0);
  auto first = open_or_fail(gpiod_config("gpiochip0"));
  ASSERT_TRUE(first);
  auto second = lights::open_gpiod_lights(gpiod_config("gpiochip0"));
  ASSERT_FALSE(second);
  EXPECT_EQ(second.error().key, "lights.gpiod.lines[0]");
  EXPECT_NE(second.error().message.find("another psrig is running"), std::string::npos)
      << second.error().message;
}

TEST_F(GpiodLights, FailedSetIsReportedWithChipAndLines) {
  auto& chip = add_chip("gpiochip0", "psrig-leds", 0);
  auto lights = open_or_fail(gpiod_config("gpiochip0"));
  ASSERT_TRUE(lights);
  chip.fail_sets(1, EIO);
  auto on = lights->turn_on(2);
  ASSERT_FALSE(on);
  EXPECT_NE(on.error().message.find(
                "switching on LED 2 (line 22) on gpiochip0 [psrig-leds] (lines 17,27,22)"),
            std::string::npos)
      << on.error().message;
  EXPECT_EQ(lights->log().on_now(), std::vector<int>{});
  // The lines' state is unknown after a failure: the next switch goes
  // through dark first.
  const auto before = chip.history().size();
  ASSERT_TRUE(lights->turn_on(2));
  const auto history = chip.history();
  ASSERT_EQ(history.size(), before + 2);
  EXPECT_EQ(history[before], levels_with(0, {}, 0));
  EXPECT_EQ(history[before + 1], levels_with(0, {22}, 1));
}

TEST_F(GpiodLights, ChipVanishingMidUseIsReportedClearly) {
  auto& chip = add_chip("gpiochip0", "psrig-leds", 0);
  auto lights = open_or_fail(gpiod_config("gpiochip0"));
  ASSERT_TRUE(lights);
  ASSERT_TRUE(lights->turn_on(0));
  chip.vanish();
  auto off = lights->all_off();
  ASSERT_FALSE(off);
  EXPECT_EQ(off.error().key, "lights.gpiod.chip");
  EXPECT_NE(off.error().message.find("gpiochip0"), std::string::npos) << off.error().message;
  EXPECT_NE(off.error().message.find("vanished"), std::string::npos) << off.error().message;
  // The log keeps what the rig knows: LED 0 was switched on and never off.
  EXPECT_EQ(lights->log().on_now(), std::vector<int>{0});
  lights.reset();  // closing a vanished chip neither hangs nor crashes
  // Reopening finds no chip at all.
  auto reopened = lights::open_gpiod_lights(gpiod_config("gpiochip0"));
  ASSERT_FALSE(reopened);
  EXPECT_NE(reopened.error().message.find("no GPIO chips found"), std::string::npos)
      << reopened.error().message;
}

// The chip goes between the safety layer switching LED 0 off and LED 1 on:
// every LED is dark, and SafeLights says what happened.
TEST_F(GpiodLights, SafeLightsOverAVanishingChipLeavesEveryLedOffAndReports) {
  auto& chip = add_chip("gpiochip0", "psrig-leds", 0);
  auto backend = open_or_fail(gpiod_config("gpiochip0"));
  ASSERT_TRUE(backend);
  SafeLights lights(std::move(backend), 5s);
  ASSERT_TRUE(lights.turn_on(0));
  chip.vanish_after(1);  // the all-off before LED 1 still reaches the lines
  auto on = lights.turn_on(1);
  ASSERT_FALSE(on);
  EXPECT_TRUE(chip.vanished());
  EXPECT_NE(on.error().message.find("switching on LED 1 (line 27) on gpiochip0"), std::string::npos)
      << on.error().message;
  EXPECT_NE(on.error().message.find("vanished"), std::string::npos) << on.error().message;
  EXPECT_NE(on.error().message.find("switching all LEDs off failed too"), std::string::npos)
      << on.error().message;
  EXPECT_EQ(lights.lit(), std::nullopt);
  const GpioLedWiring wiring{kLines, false};
  EXPECT_EQ(wiring.lit_channels(chip.levels()), std::vector<int>{});
  EXPECT_EQ(wiring.most_lit(chip.history()), 1);
  EXPECT_EQ(lights.log().overlap(), std::nullopt);
}

// Through the factory, as the daemon opens it.
TEST_F(GpiodLights, FactoryOpensGpiodAndBlamesTheConfigFile) {
  add_chip("gpiochip0", "psrig-leds", 0);
  config::RigConfig rig;
  rig.source = "/etc/psrig/rig.toml";
  rig.lights = gpiod_config("gpiochip0");
  auto lights = psrig::rig::open_lights(rig);
  ASSERT_TRUE(lights) << lights.error().describe();
  EXPECT_EQ((*lights)->describe().rfind("gpiod gpiochip0", 0), 0u) << (*lights)->describe();
  lights->reset();

  rig.lights.gpiod.lines = {17, 99, 22};
  auto bad = psrig::rig::open_lights(rig);
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().describe().rfind("/etc/psrig/rig.toml: lights.gpiod.lines[1]: ", 0), 0u)
      << bad.error().describe();
}

}  // namespace
}  // namespace psrig::test
