// The real modbus light backend against the simulated Modbus driver (a
// libmodbus server) over loopback TCP and over RTU on a pseudo-terminal
// pair: switching, intensities, register maps, the driver's fault status
// and injected faults. Every test checks the driver's own record too: never
// two LEDs on, and all off after a failure.

#include "psrig/lights/modbus_lights.h"

#include <atomic>
#include <chrono>
#include <memory>
#include <modbus.h>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "psrig/lights/safe_lights.h"
#include "psrig/rig/open_devices.h"
#include "sim_modbus_driver.h"

namespace psrig::lights {
namespace {

using std::chrono::milliseconds;
using test::kModbusStatusDriverFault;
using test::kModbusStatusInterlock;
using test::ModbusFault;
using test::SimModbusDriver;
using test::SimModbusDriverOptions;
using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

// What the simulated world would see through SimModbusDriver's callback.
class WorldProbe {
 public:
  SimModbusDriver::SwitchCallback callback() {
    return [this](int channel, bool on, double level, Clock::time_point) {
      const std::scoped_lock lock(mutex_);
      if (on)
        on_.insert(channel);
      else
        on_.erase(channel);
      max_on_ = std::max(max_on_, on_.size());
      events_.push_back({channel, on, level});
    };
  }
  struct Event {
    int channel;
    bool on;
    double level;
  };
  std::vector<Event> events() const {
    const std::scoped_lock lock(mutex_);
    return events_;
  }
  std::size_t max_on() const {
    const std::scoped_lock lock(mutex_);
    return max_on_;
  }
  std::set<int> on() const {
    const std::scoped_lock lock(mutex_);
    return on_;
  }

 private:
  mutable std::mutex mutex_;
  std::set<int> on_;
  std::size_t max_on_ = 0;
  std::vector<Event> events_;
};

class ModbusLightsTest : public ::testing::TestWithParam<std::string> {
 protected:
  // A driver on this test's transport, and a host configuration for it.
  void start_driver(const config::ModbusRegisters& registers = {}, int slave = 1) {
    SimModbusDriverOptions options;
    options.transport = GetParam();
    options.slave = slave;
    options.registers = registers;
    auto started = SimModbusDriver::start(options, world_.callback());
    ASSERT_TRUE(started.has_value()) << started.error().describe();
    driver_ = std::move(*started);
    config_.backend = "modbus";
    config_.modbus = driver_->host_config();
    config_.modbus.timeout_ms = 200;
    config_.modbus.retries = 2;
  }

  std::unique_ptr<LightController> open() {
    auto opened = open_modbus_lights(config_);
    EXPECT_TRUE(opened.has_value()) << opened.error().describe();
    return opened ? std::move(*opened) : nullptr;
  }

  // From both sides: the host's log, the driver's own switch history and
  // the world's view never show two LEDs on, and the host never even asked
  // for it (the driver's interlock would have refused).
  void expect_never_two_on(const LightController& lights) const {
    EXPECT_EQ(lights.log().overlap(), std::nullopt);
    EXPECT_EQ(driver_->log().overlap(), std::nullopt);
    EXPECT_LE(world_.max_on(), 1u);
    EXPECT_EQ(driver_->interlock_refusals(), 0);
  }

  // Enable coils written in one request, and the all-off coil.
  int coil_writes() const {
    return driver_->requests(MODBUS_FC_WRITE_MULTIPLE_COILS) +
           driver_->requests(MODBUS_FC_WRITE_SINGLE_COIL);
  }

  // "tcp 127.0.0.1:PORT" or "rtu /dev/pts/N": the endpoint errors must name.
  std::string endpoint() const {
    return GetParam() == "tcp" ? "tcp 127.0.0.1:" + std::to_string(driver_->port())
                               : "rtu " + driver_->device();
  }
  std::string endpoint_key() const {
    return GetParam() == "tcp" ? "lights.modbus.host" : "lights.modbus.device";
  }
  // Where the fix starts: a serial port can be looked for, a TCP driver pinged.
  std::string fix_hint() const {
    return GetParam() == "tcp" ? "lights.modbus.port" : "psrig devices";
  }

  WorldProbe world_;
  std::unique_ptr<SimModbusDriver> driver_;
  config::LightsConfig config_;
};

TEST_P(ModbusLightsTest, SwitchesOneLedAtATimeThroughTheCoils) {
  start_driver();
  auto lights = open();
  ASSERT_TRUE(lights);
  EXPECT_EQ(lights->channel_count(), 3);
  EXPECT_TRUE(driver_->leds_on().empty());

  for (int channel = 0; channel < 3; ++channel) {
    ASSERT_TRUE(lights->turn_on(channel).has_value());
    EXPECT_THAT(driver_->leds_on(), ElementsAre(channel));
    EXPECT_THAT(lights->log().on_now(), ElementsAre(channel));
    ASSERT_TRUE(lights->all_off().has_value());
    EXPECT_TRUE(driver_->leds_on().empty());
  }
  // Straight from one LED to the next: one request switches both coils.
  const int writes = coil_writes();
  ASSERT_TRUE(lights->turn_on(0).has_value());
  ASSERT_TRUE(lights->turn_on(2).has_value());
  EXPECT_EQ(coil_writes(), writes + 2);
  EXPECT_THAT(driver_->leds_on(), ElementsAre(2));
  EXPECT_EQ(driver_->interlock_refusals(), 0);
  EXPECT_EQ(driver_->status(), 0);

  // The world heard every switch, the off before the on.
  const auto events = world_.events();
  ASSERT_GE(events.size(), 2u);
  EXPECT_EQ(events[events.size() - 2].channel, 0);
  EXPECT_FALSE(events[events.size() - 2].on);
  EXPECT_EQ(events.back().channel, 2);
  EXPECT_TRUE(events.back().on);
  EXPECT_DOUBLE_EQ(events.back().level, 1.0);
  EXPECT_EQ(world_.on(), std::set<int>{2});
  expect_never_two_on(*lights);
}

TEST_P(ModbusLightsTest, IntensitiesLandAtTheConfiguredFullScale) {
  config::ModbusRegisters registers;
  registers.intensity_full_scale = 4000;
  start_driver(registers);
  config_.intensity = {1.0, 0.25, 0.5};
  auto lights = open();
  ASSERT_TRUE(lights);
  EXPECT_THAT(driver_->intensities(), ElementsAre(4000, 1000, 2000));

  ASSERT_TRUE(lights->set_intensity(2, 0.1).has_value());
  EXPECT_THAT(driver_->intensities(), ElementsAre(4000, 1000, 400));
  ASSERT_TRUE(lights->turn_on(1).has_value());
  EXPECT_DOUBLE_EQ(world_.events().back().level, 0.25);
  // A level change of the LED that is on reaches the world at once.
  ASSERT_TRUE(lights->set_intensity(1, 0.75).has_value());
  EXPECT_EQ(driver_->intensities()[1], 3000);
  EXPECT_DOUBLE_EQ(world_.events().back().level, 0.75);

  const auto bad = lights->set_intensity(0, 1.5);
  ASSERT_FALSE(bad.has_value());
  EXPECT_THAT(bad.error().message, HasSubstr("0 to 1"));
  EXPECT_EQ(driver_->intensities()[0], 4000);
  EXPECT_FALSE(lights->turn_on(3).has_value());
  expect_never_two_on(*lights);
}

TEST_P(ModbusLightsTest, CustomRegisterMapWorks) {
  config::ModbusRegisters registers;
  registers.enable_coil = 16;
  registers.intensity_register = 40;
  registers.intensity_full_scale = 255;
  registers.status_register = 7;
  registers.all_off_coil = 40;
  registers.id_register = 20;
  registers.device_id = 0x1234;
  start_driver(registers);
  auto lights = open();
  ASSERT_TRUE(lights);
  EXPECT_THAT(lights->describe(), HasSubstr("0x1234 firmware 1.2"));
  EXPECT_THAT(driver_->intensities(), ElementsAre(255, 255, 255));
  ASSERT_TRUE(lights->set_intensity(1, 0.2).has_value());
  EXPECT_EQ(driver_->intensities()[1], 51);
  ASSERT_TRUE(lights->turn_on(1).has_value());
  EXPECT_THAT(driver_->leds_on(), ElementsAre(1));
  driver_->set_status(kModbusStatusDriverFault);
  const auto faulted = lights->turn_on(2);
  ASSERT_FALSE(faulted.has_value());
  EXPECT_THAT(faulted.error().message, HasSubstr("status input register 7"));
  EXPECT_EQ(faulted.error().key, "lights.modbus.registers.status_register");
  EXPECT_TRUE(driver_->leds_on().empty());
  expect_never_two_on(*lights);
}

TEST_P(ModbusLightsTest, RegisterMapMismatchIsRefusedAtOpenByName) {
  start_driver();                              // the default map
  config_.modbus.registers.enable_coil = 200;  // not the driver's
  auto opened = open_modbus_lights(config_);
  ASSERT_FALSE(opened.has_value());
  EXPECT_THAT(opened.error().message,
              AllOf(HasSubstr("refused reading back the enable coils (coils 200-202, "
                              "lights.modbus.registers.enable_coil)"),
                    HasSubstr("exception 2"), HasSubstr(endpoint())));
  EXPECT_EQ(opened.error().key, "lights.modbus.registers.enable_coil");

  config_.modbus.registers = {};
  config_.modbus.registers.all_off_coil = 33;  // a gap in the driver's coils
  opened = open_modbus_lights(config_);
  ASSERT_FALSE(opened.has_value());
  EXPECT_THAT(opened.error().message,
              AllOf(HasSubstr("refused switching every LED off (writing coil 33"),
                    HasSubstr("exception 2")));
  EXPECT_EQ(opened.error().key, "lights.modbus.registers.all_off_coil");
  EXPECT_TRUE(driver_->leds_on().empty());
}

TEST_P(ModbusLightsTest, ForeignDeviceIsNamedAndNeverWrittenTo) {
  config::ModbusRegisters registers;
  registers.device_id = 0x0BAD;  // some other Modbus device on that address
  start_driver(registers);
  config_.modbus.registers.device_id = 0x4C44;
  const auto opened = open_modbus_lights(config_);
  ASSERT_FALSE(opened.has_value());
  EXPECT_THAT(opened.error().message,
              AllOf(HasSubstr(endpoint()), HasSubstr("device id 0x0bad in input register 1"),
                    HasSubstr("not 0x4c44"), HasSubstr("nothing was written")));
  EXPECT_EQ(opened.error().key, "lights.modbus.registers.device_id");
  EXPECT_EQ(driver_->requests(), 1);  // the identity read, and nothing else
  EXPECT_EQ(driver_->requests(MODBUS_FC_READ_INPUT_REGISTERS), 1);
}

TEST_P(ModbusLightsTest, WithoutAnAllOffCoilTheEnableCoilsAreCleared) {
  config::ModbusRegisters registers;
  registers.all_off_coil = -1;
  registers.id_register = -1;  // nor an identity to check
  start_driver(registers);
  auto lights = open();
  ASSERT_TRUE(lights);
  EXPECT_EQ(lights->describe().find("firmware"), std::string::npos);
  ASSERT_TRUE(lights->turn_on(1).has_value());
  EXPECT_THAT(driver_->leds_on(), ElementsAre(1));
  ASSERT_TRUE(lights->all_off().has_value());
  EXPECT_TRUE(driver_->leds_on().empty());
  EXPECT_EQ(driver_->requests(MODBUS_FC_WRITE_SINGLE_COIL), 0);
  EXPECT_EQ(driver_->requests(MODBUS_FC_READ_INPUT_REGISTERS), 2);  // status at open, after on
  expect_never_two_on(*lights);
}

TEST_P(ModbusLightsTest, AllOffCoilReachesLedsTheHostDoesNotKnow) {
  SimModbusDriverOptions options;
  options.transport = GetParam();
  options.channels = 4;  // the driver has a fourth LED, the rig's config three
  auto started = SimModbusDriver::start(options, world_.callback());
  ASSERT_TRUE(started.has_value()) << started.error().describe();
  driver_ = std::move(*started);
  config_.modbus = driver_->host_config();
  {
    // Someone left LED 3 on.
    const auto host = driver_->host_config();
    modbus_t* raw = GetParam() == "tcp" ? modbus_new_tcp("127.0.0.1", host.port)
                                        : modbus_new_rtu(host.device.c_str(), 19200, 'N', 8, 1);
    ASSERT_NE(raw, nullptr);
    modbus_set_slave(raw, 1);
    ASSERT_EQ(modbus_connect(raw), 0);
    EXPECT_EQ(modbus_write_bit(raw, 3, 1), 1);
    modbus_close(raw);
    modbus_free(raw);
  }
  EXPECT_THAT(driver_->leds_on(), ElementsAre(3));
  auto lights = open();
  ASSERT_TRUE(lights);
  EXPECT_TRUE(driver_->leds_on().empty());
  ASSERT_TRUE(lights->turn_on(0).has_value());
  EXPECT_THAT(driver_->leds_on(), ElementsAre(0));
  expect_never_two_on(*lights);
}

TEST_P(ModbusLightsTest, DriverFaultStatusIsAnErrorAndEverythingGoesOff) {
  start_driver();
  auto lights = open();
  ASSERT_TRUE(lights);
  ASSERT_TRUE(lights->turn_on(0).has_value());
  driver_->set_status(kModbusStatusDriverFault);
  const auto result = lights->turn_on(1);
  ASSERT_FALSE(result.has_value());
  EXPECT_THAT(result.error().message,
              AllOf(HasSubstr("reports a fault"), HasSubstr("status input register 0 = 0x0001"),
                    HasSubstr("slave 1"), HasSubstr("Every LED is off")));
  EXPECT_TRUE(driver_->leds_on().empty());
  EXPECT_TRUE(lights->log().on_now().empty());
  lights.reset();

  // A driver already in fault is not used at all.
  const auto reopened = open_modbus_lights(config_);
  ASSERT_FALSE(reopened.has_value());
  EXPECT_THAT(reopened.error().message, HasSubstr("at start-up"));
  EXPECT_TRUE(driver_->leds_on().empty());
  EXPECT_EQ(driver_->log().overlap(), std::nullopt);
}

TEST_P(ModbusLightsTest, NoAnswerTimesOutAfterTheConfiguredRetries) {
  start_driver();
  config_.modbus.timeout_ms = 150;
  auto lights = open();
  ASSERT_TRUE(lights);
  ASSERT_TRUE(lights->turn_on(0).has_value());
  const int writes = coil_writes();
  driver_->inject(ModbusFault::no_answer, 3);  // exactly the three attempts

  const auto began = Clock::now();
  const auto result = lights->turn_on(1);
  const auto took = Clock::now() - began;
  ASSERT_FALSE(result.has_value());
  EXPECT_THAT(result.error().message,
              AllOf(HasSubstr(endpoint()), HasSubstr("no answer switching LED 1 on"),
                    HasSubstr("coils 0-2, lights.modbus.registers.enable_coil"),
                    HasSubstr("after 3 attempts"), HasSubstr("timeout 150 ms"),
                    HasSubstr("slave 1"), HasSubstr(fix_hint()), HasSubstr("Every LED is off")));
  EXPECT_EQ(result.error().key, endpoint_key());
  EXPECT_GE(took, milliseconds(3 * 150 - 10));
  EXPECT_LT(took, milliseconds(3 * 150 + 3000));
  // Three ignored attempts, then the all-off that got through.
  EXPECT_EQ(coil_writes(), writes + 4);
  EXPECT_TRUE(driver_->leds_on().empty());
  expect_never_two_on(*lights);
}

TEST_P(ModbusLightsTest, DriverGoneSilentFailsEveryCallThenRecovers) {
  start_driver();
  config_.modbus.timeout_ms = 100;
  config_.modbus.retries = 1;
  auto lights = open();
  ASSERT_TRUE(lights);
  driver_->inject(ModbusFault::no_answer);  // until cleared
  const auto result = lights->turn_on(2);
  ASSERT_FALSE(result.has_value());
  EXPECT_THAT(result.error().message,
              AllOf(HasSubstr("after 2 attempts"), HasSubstr("Turning every LED off failed too")));
  EXPECT_TRUE(driver_->leds_on().empty());
  EXPECT_FALSE(lights->all_off().has_value());

  driver_->clear_fault();
  ASSERT_TRUE(lights->turn_on(2).has_value());
  EXPECT_THAT(driver_->leds_on(), ElementsAre(2));
  ASSERT_TRUE(lights->all_off().has_value());
  EXPECT_TRUE(driver_->leds_on().empty());
  expect_never_two_on(*lights);
}

TEST_P(ModbusLightsTest, LostReplyStillEndsWithEveryLedOff) {
  start_driver();
  config_.modbus.timeout_ms = 150;
  auto lights = open();
  ASSERT_TRUE(lights);
  // The driver carries out every attempt but the host never hears back.
  driver_->inject(ModbusFault::lost_reply, 3);
  const auto result = lights->turn_on(1);
  ASSERT_FALSE(result.has_value());
  EXPECT_THAT(result.error().message, HasSubstr("after 3 attempts"));
  // LED 1 did come on in the driver; the backend's all-off took it back.
  const auto events = driver_->log().events();
  ASSERT_GE(events.size(), 2u);
  EXPECT_EQ(events[events.size() - 2].channel, 1);
  EXPECT_TRUE(events[events.size() - 2].on);
  EXPECT_FALSE(events.back().on);
  EXPECT_TRUE(driver_->leds_on().empty());
  EXPECT_TRUE(world_.on().empty());
  expect_never_two_on(*lights);
}

TEST_P(ModbusLightsTest, OneLostReplyIsRetriedAndTheSwitchGoesThrough) {
  start_driver();
  auto lights = open();
  ASSERT_TRUE(lights);
  ASSERT_TRUE(lights->turn_on(0).has_value());
  const int writes = coil_writes();
  driver_->inject(ModbusFault::lost_reply, 1);
  ASSERT_TRUE(lights->turn_on(1).has_value());
  EXPECT_EQ(coil_writes(), writes + 2);  // the write whose reply was lost, then the retry
  EXPECT_THAT(driver_->leds_on(), ElementsAre(1));
  EXPECT_THAT(lights->log().on_now(), ElementsAre(1));
  expect_never_two_on(*lights);
}

TEST_P(ModbusLightsTest, ExceptionResponseIsNotRetriedAndEverythingGoesOff) {
  start_driver();
  auto lights = open();
  ASSERT_TRUE(lights);
  ASSERT_TRUE(lights->turn_on(0).has_value());
  const int writes = coil_writes();
  driver_->inject(ModbusFault::exception, 1, MODBUS_EXCEPTION_SLAVE_OR_SERVER_FAILURE);
  const auto result = lights->turn_on(1);
  ASSERT_FALSE(result.has_value());
  EXPECT_THAT(result.error().message,
              AllOf(HasSubstr("refused switching LED 1 on"), HasSubstr("exception 4"),
                    HasSubstr("Every LED is off")));
  EXPECT_EQ(coil_writes(), writes + 2);  // the refused write, then the all-off
  EXPECT_TRUE(driver_->leds_on().empty());
  expect_never_two_on(*lights);
}

TEST_P(ModbusLightsTest, CorruptedRepliesAreRetriedThenReported) {
  start_driver();
  config_.modbus.timeout_ms = 150;
  auto lights = open();
  ASSERT_TRUE(lights);
  // One broken reply: the retry carries the switch through.
  int writes = coil_writes();
  driver_->inject(ModbusFault::bad_crc, 1);
  ASSERT_TRUE(lights->turn_on(0).has_value());
  EXPECT_EQ(coil_writes(), writes + 2);
  EXPECT_THAT(driver_->leds_on(), ElementsAre(0));

  // Every attempt broken: a clear error, and the all-off still gets through.
  writes = coil_writes();
  driver_->inject(ModbusFault::bad_crc, 3);
  const auto result = lights->turn_on(1);
  ASSERT_FALSE(result.has_value());
  EXPECT_THAT(result.error().message,
              AllOf(HasSubstr("no valid answer switching LED 1 on"), HasSubstr("after 3 attempts"),
                    HasSubstr(GetParam() == "rtu" ? "CRC" : "data")));
  EXPECT_EQ(coil_writes(), writes + 4);
  EXPECT_TRUE(driver_->leds_on().empty());
  expect_never_two_on(*lights);
}

TEST_P(ModbusLightsTest, SecondLedIsRefusedByTheDriverInterlock) {
  start_driver();
  auto lights = open();
  ASSERT_TRUE(lights);
  {
    // A careless second client, straight on libmodbus: LED 0 on, then LED 1 on top.
    const auto host = driver_->host_config();
    modbus_t* raw = GetParam() == "tcp" ? modbus_new_tcp("127.0.0.1", host.port)
                                        : modbus_new_rtu(host.device.c_str(), 19200, 'N', 8, 1);
    ASSERT_NE(raw, nullptr);
    modbus_set_slave(raw, 1);
    modbus_set_response_timeout(raw, 0, 300'000);
    ASSERT_EQ(modbus_connect(raw), 0);
    EXPECT_EQ(modbus_write_bit(raw, 0, 1), 1);
    EXPECT_EQ(modbus_write_bit(raw, 1, 1), -1);
    EXPECT_EQ(errno, EMBXILVAL);
    const std::uint8_t both[3] = {0, 1, 1};
    EXPECT_EQ(modbus_write_bits(raw, 0, 3, both), -1);
    EXPECT_EQ(errno, EMBXILVAL);
    modbus_close(raw);
    modbus_free(raw);
  }
  EXPECT_THAT(driver_->leds_on(), ElementsAre(0));
  EXPECT_EQ(driver_->interlock_refusals(), 2);
  EXPECT_EQ(driver_->status(), kModbusStatusInterlock);
  EXPECT_EQ(driver_->log().overlap(), std::nullopt);
  EXPECT_LE(world_.max_on(), 1u);

  // The backend's next switch sees the latched fault and turns all off,
  // which acknowledges it; then the driver is usable again.
  const auto result = lights->turn_on(2);
  ASSERT_FALSE(result.has_value());
  EXPECT_THAT(result.error().message, HasSubstr("status input register 0 = 0x0002"));
  EXPECT_TRUE(driver_->leds_on().empty());
  EXPECT_EQ(driver_->status(), 0);
  ASSERT_TRUE(lights->turn_on(1).has_value());
  EXPECT_THAT(driver_->leds_on(), ElementsAre(1));
  EXPECT_EQ(lights->log().overlap(), std::nullopt);
  EXPECT_EQ(driver_->log().overlap(), std::nullopt);
  EXPECT_EQ(driver_->interlock_refusals(), 2);  // the careless client's, none of the backend's
}

TEST_P(ModbusLightsTest, ClosingTurnsEverythingOff) {
  start_driver();
  auto lights = open();
  ASSERT_TRUE(lights);
  ASSERT_TRUE(lights->turn_on(2).has_value());
  EXPECT_THAT(driver_->leds_on(), ElementsAre(2));
  lights.reset();
  EXPECT_TRUE(driver_->leds_on().empty());
  EXPECT_TRUE(world_.on().empty());
}

TEST_P(ModbusLightsTest, WrongSlaveIdIsNamedInTheError) {
  start_driver({}, 5);
  config_.modbus.slave = 6;
  config_.modbus.timeout_ms = 100;
  config_.modbus.retries = 0;
  const auto opened = open_modbus_lights(config_);
  ASSERT_FALSE(opened.has_value());
  EXPECT_THAT(opened.error().message,
              AllOf(HasSubstr("slave 6"), HasSubstr("no answer"), HasSubstr("lights.modbus.slave"),
                    HasSubstr(fix_hint())));
  EXPECT_EQ(driver_->requests(), 0);  // slave 5 never answered, nor acted

  // The driver still takes the very next request for itself, first time.
  config_.modbus.slave = 5;
  ASSERT_TRUE(open().get());
  EXPECT_GT(driver_->requests(), 0);
}

TEST_P(ModbusLightsTest, ConcurrentCallersShareTheContextSafely) {
  start_driver();
  auto lights = open();
  ASSERT_TRUE(lights);
  std::vector<std::thread> threads;
  std::atomic<int> failures = 0;
  for (int t = 0; t < 3; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < 20; ++i) {
        if (!lights->turn_on((t + i) % 3).has_value()) ++failures;
        if (!lights->set_intensity(t, 0.5).has_value()) ++failures;
      }
    });
  }
  for (auto& thread : threads)
    thread.join();
  EXPECT_EQ(failures, 0);
  EXPECT_EQ(driver_->leds_on().size(), 1u);
  EXPECT_EQ(driver_->interlock_refusals(), 0);
  ASSERT_TRUE(lights->all_off().has_value());
  EXPECT_TRUE(driver_->leds_on().empty());
  expect_never_two_on(*lights);
}

TEST_P(ModbusLightsTest, DescribesTransportAddressAndSlave) {
  start_driver();
  auto lights = open();
  ASSERT_TRUE(lights);
  if (GetParam() == "tcp")
    EXPECT_EQ(lights->describe(), "modbus LED driver 0x4c44 firmware 1.2, tcp 127.0.0.1:" +
                                      std::to_string(driver_->port()) + ", slave 1");
  else
    EXPECT_EQ(lights->describe(), "modbus LED driver 0x4c44 firmware 1.2, rtu " +
                                      driver_->device() + " 19200 8N1, slave 1");
}

// The safety layer on top: a failure half-way through a switch leaves
// every LED off in the driver, even when the host never hears back.
TEST_P(ModbusLightsTest, SafeLightsFailureLeavesEveryLedOff) {
  start_driver();
  config_.modbus.timeout_ms = 100;
  auto lights = open();
  ASSERT_TRUE(lights);
  SafeLights safe(std::move(lights), milliseconds(5000));
  ASSERT_TRUE(safe.turn_on(0).has_value());
  EXPECT_THAT(driver_->leds_on(), ElementsAre(0));

  // An LED fault shows in the status after the switch.
  driver_->set_status(kModbusStatusDriverFault);
  auto result = safe.turn_on(1);
  ASSERT_FALSE(result.has_value());
  EXPECT_THAT(result.error().message, HasSubstr("reports a fault"));
  EXPECT_TRUE(driver_->leds_on().empty());
  EXPECT_TRUE(world_.on().empty());
  EXPECT_FALSE(safe.lit().has_value());
  driver_->set_status(0);

  // The driver carries every request out, but no reply comes back.
  ASSERT_TRUE(safe.turn_on(2).has_value());
  driver_->inject(ModbusFault::lost_reply);
  result = safe.turn_on(0);
  ASSERT_FALSE(result.has_value());
  EXPECT_THAT(result.error().message, HasSubstr(endpoint()));
  EXPECT_TRUE(driver_->leds_on().empty());
  EXPECT_TRUE(world_.on().empty());
  EXPECT_FALSE(safe.lit().has_value());
  driver_->clear_fault();

  EXPECT_EQ(safe.log().overlap(), std::nullopt);
  EXPECT_EQ(driver_->log().overlap(), std::nullopt);
  EXPECT_LE(world_.max_on(), 1u);
  EXPECT_EQ(driver_->interlock_refusals(), 0);
}

TEST_P(ModbusLightsTest, SafeLightsWatchdogSwitchesTheDriverOff) {
  start_driver();
  auto lights = open();
  ASSERT_TRUE(lights);
  SafeLights safe(std::move(lights), milliseconds(100));
  ASSERT_TRUE(safe.turn_on(2).has_value());
  EXPECT_THAT(driver_->leds_on(), ElementsAre(2));
  const auto deadline = Clock::now() + std::chrono::seconds(5);
  while (!safe.timed_out() && Clock::now() < deadline)
    std::this_thread::sleep_for(milliseconds(10));
  EXPECT_TRUE(safe.timed_out());
  EXPECT_TRUE(driver_->leds_on().empty());
}

// Chosen by lights.backend, as every backend is.
TEST_P(ModbusLightsTest, FactoryOpensTheModbusBackend) {
  start_driver();
  config::RigConfig rig;
  rig.source = "/etc/psrig/rig.toml";
  rig.lights = config_;
  rig.lights.backend = "modbus";
  auto opened = psrig::rig::open_lights(rig);
  ASSERT_TRUE(opened.has_value()) << opened.error().describe();
  EXPECT_THAT((*opened)->describe(), HasSubstr(endpoint()));
  ASSERT_TRUE((*opened)->turn_on(1).has_value());
  EXPECT_THAT(driver_->leds_on(), ElementsAre(1));
  opened->reset();
  EXPECT_TRUE(driver_->leds_on().empty());

  rig.lights.modbus.timeout_ms = 0;
  opened = psrig::rig::open_lights(rig);
  ASSERT_FALSE(opened.has_value());
  EXPECT_EQ(opened.error().key, "lights.modbus.timeout_ms");
  EXPECT_EQ(opened.error().file, rig.source);
}

INSTANTIATE_TEST_SUITE_P(Modbus, ModbusLightsTest, ::testing::Values("tcp", "rtu"),
                         [](const auto& test) { return test.param; });

// Only TCP has a connection to lose.
TEST(ModbusLightsTcpTest, DroppedConnectionIsReopenedOrReported) {
  WorldProbe world;
  auto started = SimModbusDriver::start({}, world.callback());
  ASSERT_TRUE(started.has_value()) << started.error().describe();
  auto& driver = **started;
  config::LightsConfig config;
  config.modbus = driver.host_config();
  config.modbus.timeout_ms = 200;
  config.modbus.retries = 2;
  auto opened = open_modbus_lights(config);
  ASSERT_TRUE(opened.has_value()) << opened.error().describe();
  auto& lights = **opened;
  EXPECT_EQ(driver.connections(), 1);

  driver.inject(ModbusFault::drop_connection, 1);
  ASSERT_TRUE(lights.turn_on(0).has_value());
  EXPECT_EQ(driver.connections(), 2);
  EXPECT_THAT(driver.leds_on(), ElementsAre(0));

  driver.inject(ModbusFault::drop_connection, 3);
  const auto result = lights.turn_on(1);
  ASSERT_FALSE(result.has_value());
  EXPECT_THAT(result.error().message,
              AllOf(HasSubstr("lost the connection switching LED 1 on"),
                    HasSubstr("tcp 127.0.0.1:" + std::to_string(driver.port())),
                    HasSubstr("after 3 attempts"), HasSubstr("Every LED is off")));
  EXPECT_TRUE(driver.leds_on().empty());
  EXPECT_EQ(lights.log().overlap(), std::nullopt);
  EXPECT_EQ(driver.log().overlap(), std::nullopt);
  EXPECT_LE(world.max_on(), 1u);
}

TEST(ModbusLightsConfigTest, BadSettingsNameTheKey) {
  config::LightsConfig config;
  config.modbus.transport = "udp";
  auto opened = open_modbus_lights(config);
  ASSERT_FALSE(opened.has_value());
  EXPECT_EQ(opened.error().key, "lights.modbus.transport");

  config.modbus.transport = "rtu";
  config.modbus.parity = 'X';
  opened = open_modbus_lights(config);
  ASSERT_FALSE(opened.has_value());
  EXPECT_EQ(opened.error().key, "lights.modbus.parity");

  config.modbus.parity = 'E';
  config.modbus.registers.intensity_full_scale = 0;
  opened = open_modbus_lights(config);
  ASSERT_FALSE(opened.has_value());
  EXPECT_EQ(opened.error().key, "lights.modbus.registers.intensity_full_scale");

  config.modbus.registers = {};
  config.modbus.registers.all_off_coil = 2;  // one of the three enable coils
  opened = open_modbus_lights(config);
  ASSERT_FALSE(opened.has_value());
  EXPECT_EQ(opened.error().key, "lights.modbus.registers.all_off_coil");
  EXPECT_THAT(opened.error().message, HasSubstr("enable coils 0-2"));
}

TEST(ModbusLightsConfigTest, MissingSerialPortNamesTheDeviceAndTheFix) {
  config::LightsConfig config;
  config.modbus.transport = "rtu";
  config.modbus.device = "/dev/ttyNOSUCH0";
  const auto opened = open_modbus_lights(config);
  ASSERT_FALSE(opened.has_value());
  EXPECT_THAT(opened.error().describe(),
              AllOf(HasSubstr("/dev/ttyNOSUCH0"), HasSubstr("lights.modbus.device"),
                    HasSubstr("psrig devices")));
}

}  // namespace
}  // namespace psrig::lights
