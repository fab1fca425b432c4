// The usb light backend, hardware in the loop: the real libusb code path
// (enumeration through udev and sysfs, usbfs ioctls: claim, URBs submitted,
// reaped and discarded, halts cleared) against the strobe controller
// emulated by umockdev at /dev/bus/usb/001/NNN, with the simulated firmware
// behind it. Run under umockdev-wrapper; the tests skip without it.
//
// Where the emulation differs from a kernel: umockdev's device node is a
// plain file, so poll() reports it always ready and libusb reaps with
// REAPURBNDELAY in a loop while a transfer is pending, and an unplug
// raises no POLLERR; libusb learns of it from URBs that complete with
// -ESHUTDOWN and ioctls that fail with ENODEV, as when an unplug races a
// transfer on real hardware (support/usbfs_device.h).

#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "emulated_strobe_controller.h"
#include "psrig/config/rig_config.h"
#include "psrig/lights/light_controller.h"
#include "psrig/lights/usb_lights.h"
#include "psrig/rig/open_devices.h"
#include "test_support.h"
#include "umockdev_bed.h"

namespace psrig::test {
namespace {

using namespace std::chrono_literals;
using lights::open_usb_lights;
using lights::open_usb_strobe;
using lights::SwitchEvent;
namespace strobe = lights::strobe;

// Skips the test when not under umockdev-wrapper.
#define REQUIRE_UMOCKDEV() \
  if (!UmockdevBed::available()) GTEST_SKIP() << "not under umockdev-wrapper"

config::LightsConfig usb_config(std::string serial = {}, int watchdog_ms = 10000) {
  config::LightsConfig config;
  config.backend = "usb";
  config.channels = 3;
  config.usb.serial = std::move(serial);
  config.usb.timeout_ms = 200;
  // Long by default, so that a test's own commands are the ones on the wire.
  config.usb.watchdog_ms = watchdog_ms;
  return config;
}

// The largest number of channels on together anywhere in `events`.
int most_on_at_once(const std::vector<SwitchEvent>& events) {
  std::vector<int> on;
  int most = 0;
  for (const SwitchEvent& event : events) {
    if (event.channel < 0) {
      on.clear();
    } else if (event.on) {
      on.push_back(event.channel);
    } else {
      std::erase(on, event.channel);
    }
    most = std::max(most, static_cast<int>(on.size()));
  }
  return most;
}

// Waits until `done` holds, up to `limit`; returns whether it did.
template <class F>
bool eventually(F done, std::chrono::milliseconds limit = 3s) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (!done()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(5ms);
  }
  return true;
}

// The controller on the bus and the backend opened on it, heartbeats running.
class UsbHilOpened : public ::testing::Test {
 protected:
  void SetUp() override {
    REQUIRE_UMOCKDEV();
    bed_ = std::make_unique<UmockdevBed>();
    controller_ = std::make_unique<EmulatedStrobeController>(*bed_);
    auto opened = open_usb_strobe(usb_config());
    ASSERT_TRUE(opened) << opened.error().describe();
    lights_ = std::move(*opened);
  }

  std::unique_ptr<UmockdevBed> bed_;
  std::unique_ptr<EmulatedStrobeController> controller_;
  std::unique_ptr<lights::UsbStrobeLights> lights_;  // last in, first out
};

TEST(UsbHil, OpensDescribesAndStartsAllOff) {
  REQUIRE_UMOCKDEV();
  UmockdevBed bed;
  EmulatedStrobeController controller(bed);
  auto& firmware = controller.firmware();
  {
    auto lights = open_usb_strobe(usb_config({}, 1500));
    ASSERT_TRUE(lights) << lights.error().describe();
    const std::string text = (*lights)->describe();
    EXPECT_TRUE(contains(text, "1209:5053")) << text;
    EXPECT_TRUE(contains(text, "serial A17")) << text;
    EXPECT_TRUE(contains(text, "firmware 1.2.0")) << text;
    EXPECT_TRUE(contains(text, "protocol 1.0")) << text;
    EXPECT_TRUE(contains(text, "/dev/bus/usb/001/002")) << text;
    EXPECT_EQ((*lights)->channel_count(), 3);
    EXPECT_EQ(controller.device().interfaces_claimed(), 1);

    EXPECT_EQ(firmware.handled(strobe::Opcode::get_info), 1);
    EXPECT_EQ(firmware.handled(strobe::Opcode::clear_faults), 1);
    EXPECT_EQ(firmware.handled(strobe::Opcode::all_off), 1);
    EXPECT_EQ(firmware.handled(strobe::Opcode::set_intensity), 3);
    const auto status = firmware.status();
    EXPECT_TRUE(status.watchdog_armed);
    EXPECT_EQ(status.watchdog_ms, 1500);
    EXPECT_EQ(status.on_channel, strobe::no_channel);
    const auto events = (*lights)->log().events();
    ASSERT_EQ(events.size(), 1u);
    EXPECT_EQ(events[0].channel, -1);
    EXPECT_FALSE(events[0].on);
    ASSERT_TRUE((*lights)->turn_on(1));
  }
  // Closing turns everything off and lets the interface go.
  EXPECT_EQ(firmware.handled(strobe::Opcode::all_off), 2);
  EXPECT_TRUE(firmware.channels_on().empty());
  EXPECT_EQ(controller.device().interfaces_claimed(), 0);
}

TEST(UsbHil, SwitchesEachChannelAndNeverTwoAtOnce) {
  REQUIRE_UMOCKDEV();
  UmockdevBed bed;
  EmulatedStrobeController controller(bed);
  auto lights = open_usb_lights(usb_config());
  ASSERT_TRUE(lights) << lights.error().describe();
  for (int round = 0; round < 2; ++round) {
    for (int channel = 0; channel < 3; ++channel) {
      ASSERT_TRUE((*lights)->turn_on(channel));
      EXPECT_EQ(controller.firmware().channels_on(), std::vector<int>{channel});
      EXPECT_EQ((*lights)->log().on_now(), std::vector<int>{channel});
    }
  }
  ASSERT_TRUE((*lights)->all_off());
  EXPECT_TRUE(controller.firmware().channels_on().empty());

  const auto& log = (*lights)->log();
  EXPECT_EQ(log.overlap(), std::nullopt);
  EXPECT_TRUE(log.on_now().empty());
  const auto events = log.events();
  EXPECT_EQ(std::count_if(events.begin(), events.end(), [](auto& e) { return e.on; }), 6);
  // The firmware's own record: each switch on came after the last off.
  const auto history = controller.firmware().history();
  EXPECT_EQ(std::count_if(history.begin(), history.end(), [](auto& e) { return e.on; }), 6);
  EXPECT_EQ(most_on_at_once(history), 1);

  auto refused = (*lights)->turn_on(3);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().key, "lights.channels");
}

TEST(UsbHil, SetsIntensityFromTheConfigAndOnRequest) {
  REQUIRE_UMOCKDEV();
  UmockdevBed bed;
  EmulatedStrobeController controller(bed);
  auto& firmware = controller.firmware();
  auto config = usb_config();
  config.intensity = {0.5, 1.0, 0.25};
  auto lights = open_usb_lights(config);
  ASSERT_TRUE(lights) << lights.error().describe();
  EXPECT_DOUBLE_EQ(firmware.level(0), 0.5);
  EXPECT_DOUBLE_EQ(firmware.level(1), 1.0);
  EXPECT_DOUBLE_EQ(firmware.level(2), 0.25);

  ASSERT_TRUE((*lights)->turn_on(1));
  ASSERT_TRUE((*lights)->set_intensity(1, 0.3));  // at once, on the channel that is on
  EXPECT_DOUBLE_EQ(firmware.level(1), 0.3);
  EXPECT_EQ(firmware.channels_on(), std::vector<int>{1});

  auto too_bright = (*lights)->set_intensity(1, 1.5);
  ASSERT_FALSE(too_bright);
  EXPECT_EQ(too_bright.error().key, "lights.intensity");
  EXPECT_DOUBLE_EQ(firmware.level(1), 0.3);
  EXPECT_FALSE((*lights)->set_intensity(5, 0.5));
}

TEST(UsbHil, HeartbeatKeepsTheWatchdogFed) {
  REQUIRE_UMOCKDEV();
  UmockdevBed bed;
  EmulatedStrobeController controller(bed);
  auto& firmware = controller.firmware();
  firmware.start_timer();  // the watchdog runs in real time, as on the MCU
  auto lights = open_usb_lights(usb_config({}, 300));
  ASSERT_TRUE(lights) << lights.error().describe();
  ASSERT_TRUE((*lights)->turn_on(0));
  std::this_thread::sleep_for(1200ms);  // four timeouts without a command of ours
  EXPECT_EQ(firmware.status().faults, 0);
  EXPECT_EQ(firmware.channels_on(), std::vector<int>{0});
  EXPECT_GE(firmware.handled(strobe::Opcode::heartbeat), 4);
}

TEST(UsbHil, SilentHostTripsTheWatchdogAndTheFaultIsReported) {
  REQUIRE_UMOCKDEV();
  UmockdevBed bed;
  EmulatedStrobeController controller(bed);
  auto& firmware = controller.firmware();
  firmware.start_timer();
  auto opened = open_usb_strobe(usb_config({}, 200));
  ASSERT_TRUE(opened) << opened.error().describe();
  auto& lights = **opened;
  ASSERT_TRUE(lights.turn_on(1));

  lights.hold_heartbeat(true);  // the host falls silent
  ASSERT_TRUE(
      eventually([&] { return (firmware.status().faults & strobe::fault::watchdog) != 0; }));
  EXPECT_TRUE(firmware.channels_on().empty());
  EXPECT_EQ(most_on_at_once(firmware.history()), 1);

  auto refused = lights.turn_on(2);
  ASSERT_FALSE(refused);
  const std::string text = refused.error().describe();
  EXPECT_TRUE(contains(text, "watchdog")) << text;
  EXPECT_TRUE(contains(text, "lights.usb.watchdog_ms = 200")) << text;
  EXPECT_TRUE(contains(text, "1209:5053 serial A17")) << text;
  EXPECT_TRUE(firmware.channels_on().empty());
  EXPECT_TRUE(lights.log().on_now().empty());  // the host saw the controller go dark

  lights.hold_heartbeat(false);  // first, so that the watchdog does not trip again
  auto left = lights.clear_faults();
  ASSERT_TRUE(left) << left.error().describe();
  EXPECT_EQ(*left, 0);
  ASSERT_TRUE(lights.turn_on(2));
  EXPECT_EQ(firmware.channels_on(), std::vector<int>{2});
  EXPECT_EQ(lights.log().overlap(), std::nullopt);
}

TEST_F(UsbHilOpened, StalledOutEndpointIsClearedAndTheCommandRepeated) {
  auto& controller = *controller_;
  auto& lights = *lights_;
  lights.hold_heartbeat(true);  // only our commands on the wire

  controller.device().stall(strobe::endpoint_out);
  ASSERT_TRUE(lights.turn_on(1));
  EXPECT_EQ(controller.device().halts_cleared(strobe::endpoint_out), 1);
  // The stalled packet never arrived; the repeat did.
  EXPECT_EQ(controller.firmware().handled(strobe::Opcode::channel_on), 1);
  EXPECT_EQ(controller.firmware().channels_on(), std::vector<int>{1});
  ASSERT_TRUE(lights.all_off());
}

TEST_F(UsbHilOpened, StalledInEndpointIsClearedAndTheLateAnswerDropped) {
  auto& controller = *controller_;
  auto& lights = *lights_;
  lights.hold_heartbeat(true);

  controller.device().stall(strobe::endpoint_in);
  ASSERT_TRUE(lights.turn_on(2));
  EXPECT_EQ(controller.device().halts_cleared(strobe::endpoint_in), 1);
  // It ran, its answer stalled, it ran again; the first answer came late
  // and was told apart by its sequence number.
  EXPECT_EQ(controller.firmware().handled(strobe::Opcode::channel_on), 2);
  EXPECT_EQ(controller.firmware().channels_on(), std::vector<int>{2});
  auto status = lights.read_status();  // still in step
  ASSERT_TRUE(status) << status.error().describe();
  EXPECT_EQ(status->on_channel, 2);
  EXPECT_EQ(lights.log().overlap(), std::nullopt);
}

TEST_F(UsbHilOpened, EndpointThatStallsAgainEndsInAClearErrorWithTheLightsOff) {
  auto& controller = *controller_;
  auto& lights = *lights_;
  lights.hold_heartbeat(true);
  ASSERT_TRUE(lights.turn_on(0));

  controller.device().stall(strobe::endpoint_out, 2);
  auto failed = lights.turn_on(1);
  ASSERT_FALSE(failed);
  const std::string text = failed.error().describe();
  EXPECT_TRUE(contains(text, "/dev/bus/usb/001/002")) << text;
  EXPECT_TRUE(contains(text, "1209:5053 serial A17")) << text;
  EXPECT_TRUE(contains(text, "lights.usb")) << text;
  EXPECT_TRUE(contains(text, "endpoint 0x01 stalled")) << text;
  EXPECT_TRUE(contains(text, "again after its halt was cleared")) << text;
  EXPECT_TRUE(contains(text, "every LED is off")) << text;
  EXPECT_EQ(controller.device().halts_cleared(strobe::endpoint_out), 2);
  EXPECT_TRUE(controller.firmware().channels_on().empty());
  EXPECT_TRUE(lights.log().on_now().empty());

  // The link stays broken: later calls say why, without touching USB.
  const int commands = controller.firmware().handled(strobe::Opcode::all_off);
  auto again = lights.all_off();
  ASSERT_FALSE(again);
  EXPECT_EQ(again.error().message, failed.error().message);
  EXPECT_EQ(controller.firmware().handled(strobe::Opcode::all_off), commands);
}

TEST_F(UsbHilOpened, SilentControllerTimesOutWithAClearError) {
  auto& controller = *controller_;
  auto& lights = *lights_;
  lights.hold_heartbeat(true);
  controller.set_wire([](auto, auto) { return std::nullopt; });  // commands arrive, answers do not

  auto failed = lights.turn_on(0);
  ASSERT_FALSE(failed);
  const std::string text = failed.error().describe();
  EXPECT_TRUE(contains(text, "did not answer CHANNEL_ON")) << text;
  EXPECT_TRUE(contains(text, "lights.usb.timeout_ms")) << text;
  EXPECT_TRUE(contains(text, "watchdog turns every LED off")) << text;
  // The ALL_OFF that followed got through, unanswered.
  EXPECT_TRUE(controller.firmware().channels_on().empty());
  EXPECT_EQ(lights.log().overlap(), std::nullopt);
}

TEST_F(UsbHilOpened, UnplugMidUseIsAClearErrorAndTheControllerIsDark) {
  auto& controller = *controller_;
  auto& lights = *lights_;
  ASSERT_TRUE(lights.turn_on(0));
  // The cable comes out just after the controller took CHANNEL_ON 2.
  controller.set_wire([&](std::span<const std::uint8_t> command,
                          strobe::Frame answer) -> std::optional<strobe::Frame> {
    const auto decoded = strobe::decode_command(command);
    if (decoded && std::holds_alternative<strobe::ChannelOn>(decoded->request) &&
        std::get<strobe::ChannelOn>(decoded->request).channel == 2) {
      controller.unplug();
      return std::nullopt;
    }
    return answer;
  });

  auto failed = lights.turn_on(2);
  ASSERT_FALSE(failed);
  const std::string text = failed.error().describe();
  EXPECT_TRUE(contains(text, "/dev/bus/usb/001/002")) << text;
  EXPECT_TRUE(contains(text, "1209:5053 serial A17")) << text;
  EXPECT_TRUE(contains(text, "lights.usb")) << text;
  EXPECT_TRUE(contains(text, "is gone (unplugged or reset)")) << text;
  EXPECT_FALSE(controller.device().plugged());
  EXPECT_TRUE(controller.firmware().channels_on().empty());
  EXPECT_EQ(most_on_at_once(controller.firmware().history()), 1);
  EXPECT_EQ(lights.log().overlap(), std::nullopt);

  auto again = lights.turn_on(0);
  ASSERT_FALSE(again);
  EXPECT_TRUE(contains(again.error().message, "is gone")) << again.error().message;
  // And it is gone for the next open too.
  auto reopened = open_usb_lights(usb_config());
  ASSERT_FALSE(reopened);
  EXPECT_TRUE(contains(reopened.error().message, "no usb strobe controller 1209:5053 found"))
      << reopened.error().message;
}

TEST(UsbHil, PicksTheControllerBySerial) {
  REQUIRE_UMOCKDEV();
  UmockdevBed bed;
  EmulatedStrobeController first(bed, {.serial = "A17", .devnum = 2, .port = 1, .firmware = {}});
  EmulatedStrobeController second(bed, {.serial = "B22", .devnum = 3, .port = 2, .firmware = {}});

  {
    auto lights = open_usb_lights(usb_config("B22"));
    ASSERT_TRUE(lights) << lights.error().describe();
    const std::string text = (*lights)->describe();
    EXPECT_TRUE(contains(text, "serial B22")) << text;
    EXPECT_TRUE(contains(text, "/dev/bus/usb/001/003")) << text;
    EXPECT_EQ(first.firmware().handled(strobe::Opcode::get_info), 0);
    EXPECT_EQ(second.firmware().handled(strobe::Opcode::get_info), 1);
  }

  auto ambiguous = open_usb_lights(usb_config());
  ASSERT_FALSE(ambiguous);
  EXPECT_EQ(ambiguous.error().key, "lights.usb.serial");
  EXPECT_TRUE(contains(ambiguous.error().message, "A17 on /dev/bus/usb/001/002"))
      << ambiguous.error().message;

  auto missing = open_usb_lights(usb_config("Z99"));
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().key, "lights.usb");
  EXPECT_TRUE(contains(missing.error().message, "serial \"Z99\"")) << missing.error().message;
  EXPECT_TRUE(contains(missing.error().message, "serial B22 on /dev/bus/usb/001/003"))
      << missing.error().message;
}

TEST(UsbHil, ASecondOpenFindsTheControllerBusy) {
  REQUIRE_UMOCKDEV();
  UmockdevBed bed;
  EmulatedStrobeController controller(bed);
  auto lights = open_usb_lights(usb_config());
  ASSERT_TRUE(lights) << lights.error().describe();
  auto second = open_usb_lights(usb_config());
  ASSERT_FALSE(second);
  EXPECT_TRUE(contains(second.error().describe(), "/dev/bus/usb/001/002: lights.usb: "));
  EXPECT_TRUE(contains(second.error().message, "1209:5053 serial A17"));
  EXPECT_TRUE(contains(second.error().message, "another program has it")) << second.error().message;
  EXPECT_EQ(controller.device().interfaces_claimed(), 1);
}

TEST(UsbHil, RefusesAFirmwareOfAnotherProtocolMajor) {
  REQUIRE_UMOCKDEV();
  UmockdevBed bed;
  EmulatedStrobeController controller(bed);
  // A firmware of protocol 2: GET_INFO's frozen layout, another major.
  controller.set_wire([](std::span<const std::uint8_t> command, strobe::Frame answer) {
    if (command.size() > 1 && command[1] == static_cast<std::uint8_t>(strobe::Opcode::get_info))
      answer.at(5) = 2;  // after the header and the status byte
    return std::optional(answer);
  });
  auto lights = open_usb_lights(usb_config());
  ASSERT_FALSE(lights);
  EXPECT_TRUE(contains(lights.error().message, "speaks protocol 2.0")) << lights.error().message;
  EXPECT_TRUE(contains(lights.error().message, "update the controller's firmware"));
  EXPECT_EQ(controller.device().interfaces_claimed(), 0);
  EXPECT_TRUE(controller.firmware().channels_on().empty());
}

TEST(UsbHil, TheFactoryOpensTheUsbBackend) {
  REQUIRE_UMOCKDEV();
  UmockdevBed bed;
  EmulatedStrobeController controller(bed);
  config::RigConfig rig;
  rig.lights = usb_config();
  auto lights = psrig::rig::open_lights(rig);
  ASSERT_TRUE(lights) << lights.error().describe();
  EXPECT_TRUE(contains((*lights)->describe(), "usb strobe controller 1209:5053"));
}

}  // namespace
}  // namespace psrig::test
