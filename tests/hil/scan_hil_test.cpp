// Whole scans on the rig's real backends, against devices emulated in user
// space: the LEDs hang on GPIO lines of an emulated chip (the gpiod backend,
// libgpiod 1.6) and light the simulated world's LEDs; the frames come from
// an emulated V4L2 camera (the v4l2 backend, Bayer RAW12) that the
// simulated sensor renders under whatever the LEDs did during each
// exposure. A scan must recover the swatch's normals; a camera that stalls
// or vanishes and a GPIO chip that vanishes must each end the scan with a
// clear error, every LED off and no scan directory. The LED invariant is
// checked on all three sides: the backend's log, the chip's own record of
// its lines, the world's switch history.

#include <chrono>
#include <fstream>
#include <functional>
#include <linux/videodev2.h>
#include <ostream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "emulated_gpio_chip.h"
#include "emulated_v4l2_camera.h"
#include "gpio_led_wiring.h"
#include "psrig/rig/rig.h"
#include "psrig/rig/scan_sequencer.h"
#include "psrig/sim/scene_truth.h"
#include "psrig/sim/sensor.h"
#include "psrig/sim/world.h"
#include "shipped_swatch.h"
#include "test_support.h"
#include "umockdev_bed.h"

namespace psrig::rig {
namespace {

using namespace std::chrono_literals;

#define SKIP_WITHOUT_UMOCKDEV() \
  if (!test::UmockdevBed::available()) GTEST_SKIP() << "not under umockdev-wrapper"

constexpr int kWidth = 256;
constexpr int kHeight = 192;

config::RigConfig hil_config() {
  config::RigConfig c;
  c.source = "scan_hil_test.toml";
  c.lights.backend = "gpiod";
  c.lights.gpiod.chip = "psrig-sim";  // by label
  c.lights.gpiod.lines = {3, 5, 7};
  c.lights.gpiod.active_low = true;
  c.camera.backend = "v4l2";
  c.camera.device = "/dev/video0";
  c.camera.format = "auto";
  c.camera.width = kWidth;
  c.camera.height = kHeight;
  c.camera.exposure_us = 20000;
  c.camera.frames_average = 2;
  c.camera.frames_discard = 0;
  c.camera.timeout_ms = 300;
  c.capture.settle_ms = 5;
  c.sim.width = kWidth;
  c.sim.height = kHeight;
  return c;
}

// The emulated devices, wired to one simulated world; the camera offers
// 8-bit grey and `sensor_format`, which "auto" picks for its depth.
struct EmulatedRig {
  explicit EmulatedRig(std::uint32_t sensor_format = V4L2_PIX_FMT_Y12) : format(sensor_format) {
    wiring.connect(chip, test::GpioLedWiring::to_leds(sim::SimulatedLeds::attach(config)));
  }

  std::uint32_t format;
  config::RigConfig config = hil_config();
  // Found through the configuration, as the sim backends find it; lit by
  // the same LEDs the chip's wiring switches.
  std::shared_ptr<sim::World> world = test::made(sim::World::attach(config));
  test::GpioLedWiring wiring{config.lights.gpiod.lines, config.lights.gpiod.active_low};
  sim::Sensor sensor{config.sim, 11};
  test::UmockdevBed bed;
  test::EmulatedGpioChip chip{
      bed, {.name = "gpiochip0", .label = "psrig-sim", .lines = 8, .initial_level = 1}};
  test::EmulatedV4l2Camera camera{bed,
                                  {.name = "video0",
                                   .formats = {V4L2_PIX_FMT_GREY, format},
                                   .sizes = {{kWidth, kHeight}},
                                   .frame_interval = 35ms,
                                   .readout = 15ms,
                                   .auto_exposure = true},
                                  [this](const test::FrameRequest& r) {
                                    sim::SensorSettings settings;
                                    settings.exposure_us = r.exposure_us;
                                    settings.gain = r.gain;
                                    settings.channels = r.channels;
                                    return sensor.expose(*world, r.exposure_start, settings,
                                                         r.sequence);
                                  }};

  // Never two LEDs on, and all off now, as the backend, the chip and the
  // world each saw it.
  void expect_led_invariant(const lights::SafeLights* lights) const {
    if (lights) {
      EXPECT_FALSE(lights->log().overlap()) << *lights->log().overlap();
      EXPECT_TRUE(lights->log().on_now().empty());
    }
    EXPECT_LE(wiring.most_lit(chip.history()), 1);
    EXPECT_TRUE(wiring.lit_channels(chip.levels()).empty());
    EXPECT_FALSE(world->leds()->log().overlap()) << *world->leds()->log().overlap();
    EXPECT_TRUE(world->leds()->leds_on().empty());
  }
};

struct Opened {
  Rig rig;
  std::unique_ptr<ScanSequencer> sequencer;
};

// The emulated camera shows the simulated world, so its scans carry the
// world's answer as a simulated camera's do.
Opened open(EmulatedRig& emulated) {
  RigWrappers truth;
  truth.camera = [&](std::unique_ptr<cameras::Camera> camera) {
    return sim::with_scene_truth(std::move(camera), emulated.world,
                                 emulated.config.sim.swatch_rotation_deg);
  };
  auto rig = open_rig(emulated.config, true, truth);
  EXPECT_TRUE(rig) << (rig ? "" : rig.error().describe());
  if (!rig) return {};
  Opened opened{std::move(*rig), nullptr};
  opened.sequencer =
      std::make_unique<ScanSequencer>(emulated.config, *opened.rig.lights, *opened.rig.camera);
  return opened;
}

ScanRequest request_into(const test::TempDir& dir) {
  ScanRequest request;
  request.directory = dir / "scan";
  request.sample_id = "HIL-1";
  return request;
}

struct SensorCase {
  std::uint32_t fourcc;
  const char* name;       // as describe() shows it
  double mean_error_deg;  // bounds on the angular error against the ground truth
  double median_error_deg;
};

void PrintTo(const SensorCase& sensor, std::ostream* out) {
  *out << sensor.name;
}

class ScanHilSensor : public ::testing::TestWithParam<SensorCase> {};

// A monochrome 12-bit sensor is the rig's camera: as good as the simulated
// one. A Bayer sensor's demosaicing (bilinear) blurs each frame alike, which
// a textured swatch pays for at the yarn edges: the median stays low, the
// mean rises.
INSTANTIATE_TEST_SUITE_P(Sensors, ScanHilSensor,
                         ::testing::Values(SensorCase{V4L2_PIX_FMT_Y12, "Y12", 1.0, 0.8},
                                           SensorCase{V4L2_PIX_FMT_SRGGB12, "RG12", 2.5, 1.2}),
                         [](const auto& sensor) { return std::string(sensor.param.name); });

TEST_P(ScanHilSensor, GpiodAndV4l2ScanRecoversTheSwatch) {
  SKIP_WITHOUT_UMOCKDEV();
  test::TempDir dir;
  EmulatedRig emulated(GetParam().fourcc);
  auto opened = open(emulated);
  ASSERT_TRUE(opened.sequencer);
  EXPECT_NE(opened.rig.camera->describe().find(GetParam().name), std::string::npos)
      << opened.rig.camera->describe();
  auto outcome = opened.sequencer->capture(request_into(dir));
  ASSERT_TRUE(outcome) << outcome.error().describe();
  ASSERT_TRUE(outcome->maps);
  const auto& error = outcome->maps->report["ground_truth"]["angular_error_deg"];
  EXPECT_LE(error["mean"].get<double>(), GetParam().mean_error_deg) << error.dump();
  EXPECT_LE(error["median"].get<double>(), GetParam().median_error_deg) << error.dump();
  RecordProperty("mean_angular_error_deg", std::to_string(error["mean"].get<double>()));
  EXPECT_EQ(outcome->timing.frames_kept, 8);
  // The camera ran with the exposure asked for, the lights were the chip's.
  EXPECT_EQ(emulated.camera.control(V4L2_CID_EXPOSURE_ABSOLUTE), 200);
  std::ifstream scan_json(dir / "scan/scan.json");
  const auto description = nlohmann::json::parse(scan_json);
  EXPECT_EQ(description["capture"]["exposure_us"], 20000);
  EXPECT_NE(description["capture"]["lights"].get<std::string>().find("gpiochip0"),
            std::string::npos)
      << description["capture"]["lights"];
  emulated.expect_led_invariant(opened.rig.lights.get());
}

// A scan that `fault` breaks when it reaches `step`: it must fail, leave no
// scan directory and keep the LED invariant; returns its error message.
std::string broken_scan(EmulatedRig& emulated, const std::string& step,
                        const std::function<void()>& fault, bool check_backend = true) {
  test::TempDir dir;
  auto opened = open(emulated);
  if (!opened.sequencer) return "the rig did not open";
  auto outcome = opened.sequencer->capture(request_into(dir), [&](const ScanProgress& p) {
    if (p.step == step) fault();
  });
  EXPECT_FALSE(outcome);
  EXPECT_FALSE(std::filesystem::exists(dir / "scan"));
  emulated.expect_led_invariant(check_backend ? opened.rig.lights.get() : nullptr);
  return outcome ? "" : outcome.error().describe();
}

TEST(ScanHil, CameraStallingMidScanEndsWithAllLedsOff) {
  SKIP_WITHOUT_UMOCKDEV();
  EmulatedRig emulated;
  const std::string message =
      broken_scan(emulated, "light 2 of 3", [&] { emulated.camera.stall(); });
  EXPECT_NE(message.find("/dev/video0"), std::string::npos) << message;
  EXPECT_NE(message.find("no frame within 300 ms"), std::string::npos) << message;
}

TEST(ScanHil, CameraVanishingMidScanEndsWithAllLedsOff) {
  SKIP_WITHOUT_UMOCKDEV();
  EmulatedRig emulated;
  const std::string message =
      broken_scan(emulated, "light 3 of 3", [&] { emulated.camera.unplug(); });
  EXPECT_NE(message.find("/dev/video0"), std::string::npos) << message;
  EXPECT_NE(message.find("vanished"), std::string::npos) << message;
}

TEST(ScanHil, GpioChipVanishingMidScanEndsWithAllLedsOff) {
  SKIP_WITHOUT_UMOCKDEV();
  EmulatedRig emulated;
  // Gone right after the switch that darkens the first LED, before the
  // second lights: every LED is dark then, and stays so with no one driving
  // the lines. (The backend's own log cannot record an all-off it could
  // not confirm, so only the chip and the world are asked.)
  const std::string message = broken_scan(
      emulated, "light 1 of 3", [&] { emulated.chip.vanish_after(1); }, /*check_backend=*/false);
  EXPECT_NE(message.find("gpiochip0"), std::string::npos) << message;
  EXPECT_TRUE(emulated.chip.vanished());
}

}  // namespace
}  // namespace psrig::rig
