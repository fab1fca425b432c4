// The USB strobe controller's protocol (lights/PROTOCOL.md): the
// codec both sides share, and the simulated firmware's safety rules on a
// clock driven by hand.

#include <atomic>
#include <chrono>
#include <map>
#include <thread>

#include <gtest/gtest.h>

#include "psrig/lights/strobe_protocol.h"
#include "strobe_firmware.h"

namespace psrig::lights {
namespace {

using namespace std::chrono_literals;
namespace fault = strobe::fault;
using strobe::Frame;
using strobe::Opcode;
using strobe::StatusCode;
using test::StrobeFirmware;

// ---------------------------------------------------------------- codec

TEST(StrobeProtocol, CommandsHaveTheDocumentedLittleEndianLayout) {
  EXPECT_EQ(encode(strobe::Command{7, strobe::SetIntensity{2, 750}}),
            (Frame{0x50, 0x12, 0x07, 0x03, 0x02, 0xEE, 0x02}));
  EXPECT_EQ(encode(strobe::Command{0xFF, strobe::Strobe{1, 0x01020304}}),
            (Frame{0x50, 0x13, 0xFF, 0x05, 0x01, 0x04, 0x03, 0x02, 0x01}));
  EXPECT_EQ(encode(strobe::Command{1, strobe::AllOff{}}), (Frame{0x50, 0x11, 0x01, 0x00}));
  EXPECT_EQ(encode(strobe::Command{2, strobe::SetWatchdog{1000}}),
            (Frame{0x50, 0x04, 0x02, 0x02, 0xE8, 0x03}));
}

TEST(StrobeProtocol, EveryCommandRoundTrips) {
  const std::vector<strobe::Request> requests = {
      strobe::GetInfo{},          strobe::GetStatus{},           strobe::Heartbeat{},
      strobe::SetWatchdog{65535}, strobe::ClearFaults{0x8011},   strobe::ChannelOn{7},
      strobe::AllOff{},           strobe::SetIntensity{1, 1000}, strobe::Strobe{2, 4'000'000'000u},
  };
  std::uint8_t seq = 250;
  for (const strobe::Request& request : requests) {
    const strobe::Command command{seq++, request};
    const Frame bytes = encode(command);
    const auto decoded = strobe::decode_command(bytes);
    ASSERT_TRUE(decoded) << to_string(opcode_of(request)) << ": " << decoded.error().reason;
    EXPECT_EQ(decoded->seq, command.seq);
    EXPECT_EQ(decoded->request.index(), request.index());
    EXPECT_EQ(encode(*decoded), bytes) << to_string(opcode_of(request));
  }
}

TEST(StrobeProtocol, EveryResultRoundTrips) {
  const strobe::DeviceInfo info{1, 0, {1, 2, 3}, 3, 1000, 50, 10000, 1'000'000};
  const strobe::DeviceStatus status{
      fault::watchdog | fault::led_open, 2, true, true, 0b100, -123, 750};
  const std::vector<strobe::Response> responses = {
      {Opcode::get_info, 1, StatusCode::ok, info},
      {Opcode::get_status, 2, StatusCode::ok, status},
      {Opcode::heartbeat, 3, StatusCode::ok, strobe::HeartbeatReply{fault::bad_command, 0xFF}},
      {Opcode::clear_faults, 4, StatusCode::ok, strobe::FaultsReply{fault::over_temperature}},
      {Opcode::channel_on, 5, StatusCode::ok, {}},
      {Opcode::channel_on, 6, StatusCode::faulted, {}},
      {Opcode::get_info, 7, StatusCode::bad_length, {}},
  };
  for (const strobe::Response& response : responses) {
    const Frame bytes = encode(response);
    const auto decoded = strobe::decode_response(bytes);
    ASSERT_TRUE(decoded) << decoded.error();
    EXPECT_EQ(decoded->opcode, response.opcode);
    EXPECT_EQ(decoded->seq, response.seq);
    EXPECT_EQ(decoded->status, response.status);
    EXPECT_EQ(decoded->result, response.result) << to_string(response.opcode);
  }
  // A refusal is the status byte alone.
  EXPECT_EQ(encode(strobe::Response{Opcode::channel_on, 9, StatusCode::faulted, {}}),
            (Frame{0x70, 0x10, 0x09, 0x01, 0x05}));
}

TEST(StrobeProtocol, MalformedCommandsAreRejectedWithTheRightStatus) {
  struct Case {
    const char* what;
    Frame bytes;
    StatusCode status;
  };
  const std::vector<Case> cases = {
      {"too short for a header", {0x50, 0x01, 0x02}, StatusCode::bad_frame},
      {"response magic", {0x70, 0x01, 0x02, 0x00}, StatusCode::bad_frame},
      {"length field beyond the transfer", {0x50, 0x10, 0x02, 0x02, 0x01}, StatusCode::bad_frame},
      {"bytes beyond the length field", {0x50, 0x11, 0x02, 0x00, 0x00}, StatusCode::bad_frame},
      {"longer than a packet", Frame(65, 0x50), StatusCode::bad_frame},
      {"unknown opcode", {0x50, 0x7E, 0x02, 0x00}, StatusCode::unknown_opcode},
      {"CHANNEL_ON without its channel", {0x50, 0x10, 0x02, 0x00}, StatusCode::bad_length},
      {"ALL_OFF with an argument", {0x50, 0x11, 0x02, 0x01, 0x00}, StatusCode::bad_length},
      {"STROBE with a 16-bit length",
       {0x50, 0x13, 0x02, 0x03, 0x00, 0x10, 0x00},
       StatusCode::bad_length},
  };
  for (const Case& c : cases) {
    const auto decoded = strobe::decode_command(c.bytes);
    ASSERT_FALSE(decoded) << c.what;
    EXPECT_EQ(decoded.error().status, c.status) << c.what;
    EXPECT_FALSE(decoded.error().reason.empty()) << c.what;
  }
  // The rejection echoes what the answer needs.
  const auto unknown = strobe::decode_command(Frame{0x50, 0x7E, 0x2A, 0x00});
  ASSERT_FALSE(unknown);
  EXPECT_EQ(unknown.error().opcode, 0x7E);
  EXPECT_EQ(unknown.error().seq, 0x2A);
}

TEST(StrobeProtocol, MalformedResponsesAreRejected) {
  EXPECT_FALSE(strobe::decode_response(Frame{0x50, 0x01, 0x00, 0x01, 0x00}));  // command magic
  EXPECT_FALSE(strobe::decode_response(Frame{0x70, 0x11, 0x00, 0x00}));        // no status byte
  EXPECT_FALSE(strobe::decode_response(Frame{0x70, 0x11, 0x00, 0x01, 0x09}));  // unknown status
  EXPECT_FALSE(strobe::decode_response(Frame{0x70, 0x11, 0x00, 0x02, 0x00}));  // length lies
  // GET_INFO cut short.
  Frame info = encode(strobe::Response{Opcode::get_info, 0, StatusCode::ok, strobe::DeviceInfo{}});
  info.pop_back();
  info[3] = static_cast<std::uint8_t>(info.size() - strobe::header_size);
  const auto cut = strobe::decode_response(info);
  ASSERT_FALSE(cut);
  EXPECT_NE(cut.error().find("GET_INFO"), std::string::npos) << cut.error();
}

TEST(StrobeProtocol, NewerMinorVersionsMayAppendResultFields) {
  strobe::DeviceInfo info{1, 3, {2, 0, 0}, 4, 1000, 50, 10000, 500'000};
  Frame bytes = encode(strobe::Response{Opcode::get_info, 5, StatusCode::ok, info});
  bytes.insert(bytes.end(), {0xAA, 0xBB});
  bytes[3] = static_cast<std::uint8_t>(bytes[3] + 2);
  const auto decoded = strobe::decode_response(bytes);
  ASSERT_TRUE(decoded) << decoded.error();
  EXPECT_EQ(std::get<strobe::DeviceInfo>(decoded->result), info);
}

TEST(StrobeProtocol, FaultsAreDescribedByName) {
  EXPECT_EQ(strobe::describe_faults(0), "none");
  const std::string text = strobe::describe_faults(fault::watchdog | fault::led_short | 0x0100);
  EXPECT_NE(text.find("watchdog"), std::string::npos) << text;
  EXPECT_NE(text.find("LED short"), std::string::npos) << text;
  EXPECT_NE(text.find("0x100"), std::string::npos) << text;
  EXPECT_EQ(text.find("open"), std::string::npos) << text;
}

// ------------------------------------------------------------- firmware

// Talks to a firmware on a clock the test moves.
class Bench {
 public:
  explicit Bench(StrobeFirmware::Options options = {})
      : firmware_(options, [this](int channel, bool on, double level, Clock::time_point at) {
          switches_.push_back({channel, on, level, at});
        }) {}

  strobe::Response send(const strobe::Request& request) {
    const Frame reply = firmware_.receive(encode(strobe::Command{seq_, request}), now_);
    auto decoded = strobe::decode_response(reply);
    EXPECT_TRUE(decoded) << decoded.error();
    EXPECT_EQ(decoded->seq, seq_);
    EXPECT_EQ(decoded->opcode, opcode_of(request));
    ++seq_;
    return *decoded;
  }
  StatusCode status_of(const strobe::Request& request) { return send(request).status; }
  strobe::DeviceStatus status() {
    return std::get<strobe::DeviceStatus>(send(strobe::GetStatus{}).result);
  }
  void wait(Clock::duration span) {
    now_ += span;
    firmware_.advance(now_);
  }

  struct Switch {
    int channel;
    bool on;
    double level;
    Clock::time_point at;
  };
  StrobeFirmware firmware_;
  std::vector<Switch> switches_;
  Clock::time_point start_ = Clock::now();
  Clock::time_point now_ = start_;
  std::uint8_t seq_ = 0;
};

// The most channels on together over the firmware's own record.
int most_on_together(const std::vector<SwitchEvent>& history) {
  std::map<int, bool> on;
  int most = 0;
  for (const SwitchEvent& event : history) {
    on[event.channel] = event.on;
    int count = 0;
    for (const auto& [channel, lit] : on)
      count += lit ? 1 : 0;
    most = std::max(most, count);
  }
  return most;
}

TEST(StrobeFirmware, NeverTurnsTwoChannelsOnAndBreaksBeforeMaking) {
  Bench bench;
  ASSERT_EQ(bench.status_of(strobe::ChannelOn{0}), StatusCode::ok);
  bench.wait(1ms);
  ASSERT_EQ(bench.status_of(strobe::ChannelOn{1}), StatusCode::ok);  // no ALL_OFF in between
  bench.wait(1ms);
  ASSERT_EQ(bench.status_of(strobe::Strobe{2, 500}), StatusCode::ok);
  ASSERT_EQ(bench.status_of(strobe::ChannelOn{0}), StatusCode::ok);
  EXPECT_EQ(bench.firmware_.channels_on(), std::vector<int>{0});
  EXPECT_EQ(bench.status().on_channel, 0);

  const std::vector<SwitchEvent> history = bench.firmware_.history();
  EXPECT_EQ(most_on_together(history), 1);
  ASSERT_EQ(history.size(), 7u);  // on 0, off 0, on 1, off 1, on 2, off 2, on 0
  for (std::size_t i = 1; i < history.size(); ++i) {
    EXPECT_NE(history[i].on, history[i - 1].on) << "event " << i;
    EXPECT_GE(history[i].time, history[i - 1].time);
  }
  // The world saw the same.
  ASSERT_EQ(bench.switches_.size(), history.size());
  EXPECT_EQ(bench.switches_[2].channel, 1);
  EXPECT_TRUE(bench.switches_[2].on);
}

TEST(StrobeFirmware, WatchdogTripsWithoutHeartbeatTurnsAllOffAndLatches) {
  Bench bench;
  ASSERT_EQ(bench.status_of(strobe::SetWatchdog{200}), StatusCode::ok);
  ASSERT_EQ(bench.status_of(strobe::ChannelOn{1}), StatusCode::ok);
  // Heartbeats inside the timeout keep it on.
  for (int i = 0; i < 5; ++i) {
    bench.wait(150ms);
    ASSERT_EQ(bench.status_of(strobe::Heartbeat{}), StatusCode::ok);
  }
  EXPECT_EQ(bench.firmware_.channels_on(), std::vector<int>{1});
  const Clock::time_point last_heartbeat = bench.now_;

  bench.wait(199ms);
  EXPECT_EQ(bench.firmware_.channels_on(), std::vector<int>{1});
  bench.wait(50ms);
  EXPECT_TRUE(bench.firmware_.channels_on().empty());
  const strobe::DeviceStatus tripped = bench.firmware_.status();
  EXPECT_TRUE(tripped.faults & fault::watchdog);
  EXPECT_FALSE(tripped.watchdog_armed);
  // Off at the deadline itself, not when someone looked.
  ASSERT_FALSE(bench.switches_.empty());
  EXPECT_FALSE(bench.switches_.back().on);
  EXPECT_EQ(bench.switches_.back().at, last_heartbeat + 200ms);

  // Latched: refused until cleared; ALL_OFF always works.
  EXPECT_EQ(bench.status_of(strobe::ChannelOn{1}), StatusCode::faulted);
  EXPECT_EQ(bench.status_of(strobe::Strobe{1, 100}), StatusCode::faulted);
  EXPECT_EQ(bench.status_of(strobe::AllOff{}), StatusCode::ok);
  EXPECT_TRUE(bench.firmware_.channels_on().empty());
  const auto cleared = bench.send(strobe::ClearFaults{fault::all});
  EXPECT_EQ(std::get<strobe::FaultsReply>(cleared.result).faults, 0);
  EXPECT_EQ(bench.status_of(strobe::ChannelOn{1}), StatusCode::ok);
  EXPECT_EQ(bench.firmware_.channels_on(), std::vector<int>{1});
}

TEST(StrobeFirmware, WatchdogIsIdleUntilAHostSpeaks) {
  Bench bench;
  bench.wait(1h);
  EXPECT_EQ(bench.firmware_.status().faults, 0);
  EXPECT_FALSE(bench.firmware_.status().watchdog_armed);
  ASSERT_EQ(bench.status_of(strobe::GetInfo{}), StatusCode::ok);
  EXPECT_TRUE(bench.firmware_.status().watchdog_armed);
  bench.wait(999ms);  // the 1000 ms default
  EXPECT_EQ(bench.firmware_.status().faults, 0);
  bench.wait(2ms);
  EXPECT_EQ(bench.firmware_.status().faults, fault::watchdog);
}

TEST(StrobeFirmware, StrobeEndsByItselfOnTime) {
  Bench bench;
  ASSERT_EQ(bench.status_of(strobe::SetIntensity{0, 250}), StatusCode::ok);
  const Clock::time_point fired = bench.now_;
  ASSERT_EQ(bench.status_of(strobe::Strobe{0, 1500}), StatusCode::ok);
  EXPECT_TRUE(bench.firmware_.status().strobing);
  bench.wait(1499us);
  EXPECT_EQ(bench.firmware_.channels_on(), std::vector<int>{0});
  bench.wait(5ms);
  EXPECT_TRUE(bench.firmware_.channels_on().empty());
  EXPECT_FALSE(bench.firmware_.status().strobing);
  ASSERT_EQ(bench.switches_.size(), 2u);
  EXPECT_EQ(bench.switches_[0].at, fired);
  EXPECT_DOUBLE_EQ(bench.switches_[0].level, 0.25);
  EXPECT_EQ(bench.switches_[1].at, fired + 1500us);
  EXPECT_FALSE(bench.switches_[1].on);
}

TEST(StrobeFirmware, ANewCommandReplacesAStrobe) {
  Bench bench;
  ASSERT_EQ(bench.status_of(strobe::Strobe{0, 1000}), StatusCode::ok);
  ASSERT_EQ(bench.status_of(strobe::ChannelOn{1}), StatusCode::ok);
  bench.wait(5ms);  // the strobe's end does not switch channel 1 off
  EXPECT_EQ(bench.firmware_.channels_on(), std::vector<int>{1});
  EXPECT_EQ(most_on_together(bench.firmware_.history()), 1);
}

TEST(StrobeFirmware, BadCommandsAreAnsweredFlaggedAndChangeNothing) {
  Bench bench;
  ASSERT_EQ(bench.status_of(strobe::ChannelOn{2}), StatusCode::ok);
  EXPECT_EQ(bench.status_of(strobe::ChannelOn{3}), StatusCode::bad_argument);
  EXPECT_EQ(bench.status_of(strobe::SetIntensity{0, 1001}), StatusCode::bad_argument);
  EXPECT_EQ(bench.status_of(strobe::Strobe{0, 0}), StatusCode::bad_argument);
  EXPECT_EQ(bench.status_of(strobe::Strobe{0, 1'000'001}), StatusCode::bad_argument);
  EXPECT_EQ(bench.status_of(strobe::SetWatchdog{10}), StatusCode::bad_argument);
  EXPECT_EQ(bench.firmware_.channels_on(), std::vector<int>{2});
  EXPECT_DOUBLE_EQ(bench.firmware_.level(0), 1.0);

  // Frames the codec rejects are still answered, one for one.
  const auto answer = [&](const Frame& bytes) {
    const auto decoded = strobe::decode_response(bench.firmware_.receive(bytes, bench.now_));
    EXPECT_TRUE(decoded) << decoded.error();
    return *decoded;
  };
  const strobe::Response unknown = answer({0x50, 0x7E, 0x33, 0x00});
  EXPECT_EQ(unknown.status, StatusCode::unknown_opcode);
  EXPECT_EQ(unknown.seq, 0x33);
  EXPECT_EQ(static_cast<int>(unknown.opcode), 0x7E);
  EXPECT_EQ(answer({0xDE, 0xAD}).status, StatusCode::bad_frame);
  EXPECT_EQ(answer({0x50, 0x10, 0x01, 0x00}).status, StatusCode::bad_length);
  EXPECT_TRUE(bench.firmware_.receive(Frame{}, bench.now_).empty());  // a ZLP gets no answer

  const strobe::DeviceStatus status = bench.status();
  EXPECT_EQ(status.faults, fault::bad_command);
  EXPECT_EQ(status.on_channel, 2);
  // Not a blocking fault.
  EXPECT_EQ(bench.status_of(strobe::ChannelOn{0}), StatusCode::ok);
  EXPECT_EQ(bench.firmware_.handled(Opcode::channel_on), 2);
}

TEST(StrobeFirmware, OverTemperatureTurnsAllOffAndStaysLatchedWhileHot) {
  Bench bench;
  ASSERT_EQ(bench.status_of(strobe::ChannelOn{0}), StatusCode::ok);
  bench.firmware_.set_temperature(82.5, bench.now_);
  EXPECT_TRUE(bench.firmware_.channels_on().empty());
  EXPECT_EQ(bench.status().temperature_decidegrees, 825);
  const auto still = bench.send(strobe::ClearFaults{fault::all});
  EXPECT_EQ(std::get<strobe::FaultsReply>(still.result).faults, fault::over_temperature);
  EXPECT_EQ(bench.status_of(strobe::ChannelOn{0}), StatusCode::faulted);
  bench.firmware_.set_temperature(40, bench.now_);
  const auto cool = bench.send(strobe::ClearFaults{fault::over_temperature});
  EXPECT_EQ(std::get<strobe::FaultsReply>(cool.result).faults, 0);
  EXPECT_EQ(bench.status_of(strobe::ChannelOn{0}), StatusCode::ok);
}

TEST(StrobeFirmware, BrokenLedIsFoundWhenDrivenAndLatched) {
  Bench bench;
  bench.firmware_.set_led_fault(2, StrobeFirmware::LedFault::open);
  ASSERT_EQ(bench.status_of(strobe::ChannelOn{2}), StatusCode::ok);
  EXPECT_TRUE(bench.firmware_.channels_on().empty());
  strobe::DeviceStatus status = bench.status();
  EXPECT_EQ(status.faults, fault::led_open);
  EXPECT_EQ(status.led_fault_channels, 0b100);
  EXPECT_EQ(bench.status_of(strobe::ChannelOn{0}), StatusCode::faulted);

  // A short found while on.
  ASSERT_EQ(bench.send(strobe::ClearFaults{fault::all}).status, StatusCode::ok);
  bench.firmware_.set_led_fault(2, StrobeFirmware::LedFault::none);
  ASSERT_EQ(bench.status_of(strobe::ChannelOn{1}), StatusCode::ok);
  bench.firmware_.set_led_fault(1, StrobeFirmware::LedFault::shorted);
  EXPECT_TRUE(bench.firmware_.channels_on().empty());
  status = bench.status();
  EXPECT_EQ(status.faults, fault::led_short);
  EXPECT_EQ(status.led_fault_channels, 0b010);
}

TEST(StrobeFirmware, IntensityAppliesAtOnceToTheChannelOn) {
  Bench bench;
  ASSERT_EQ(bench.status_of(strobe::ChannelOn{1}), StatusCode::ok);
  ASSERT_EQ(bench.status_of(strobe::SetIntensity{1, 400}), StatusCode::ok);
  ASSERT_EQ(bench.switches_.size(), 2u);
  EXPECT_TRUE(bench.switches_[1].on);
  EXPECT_DOUBLE_EQ(bench.switches_[1].level, 0.4);
  EXPECT_DOUBLE_EQ(bench.firmware_.level(1), 0.4);
  EXPECT_EQ(bench.firmware_.history().size(), 1u);  // a level change is not a switch
}

TEST(StrobeFirmware, InfoReportsVersionAndLimits) {
  StrobeFirmware::Options options;
  options.channels = 4;
  options.firmware = {2, 7, 1};
  Bench bench(options);
  const auto info = std::get<strobe::DeviceInfo>(bench.send(strobe::GetInfo{}).result);
  EXPECT_EQ(info.protocol_major, strobe::protocol_major);
  EXPECT_EQ(info.firmware, (strobe::Version{2, 7, 1}));
  EXPECT_EQ(info.channels, 4);
  EXPECT_EQ(info.intensity_full_scale, 1000);
  EXPECT_EQ(bench.status_of(strobe::ChannelOn{3}), StatusCode::ok);
}

TEST(StrobeFirmware, UsbDisconnectTurnsAllOffAndIdlesTheWatchdog) {
  Bench bench;
  ASSERT_EQ(bench.status_of(strobe::ChannelOn{0}), StatusCode::ok);
  bench.firmware_.usb_disconnect(bench.now_);
  EXPECT_TRUE(bench.firmware_.channels_on().empty());
  bench.wait(10s);
  EXPECT_EQ(bench.firmware_.status().faults, 0);  // no host to report a watchdog to
}

TEST(StrobeFirmware, TimerThreadTripsTheWatchdogInRealTime) {
  std::atomic<int> offs = 0;
  StrobeFirmware firmware({}, [&](int, bool on, double, Clock::time_point) {
    if (!on) ++offs;
  });
  firmware.start_timer();
  const auto send = [&](const strobe::Request& request) {
    return strobe::decode_response(firmware.receive(encode(strobe::Command{0, request})))->status;
  };
  ASSERT_EQ(send(strobe::SetWatchdog{50}), StatusCode::ok);
  ASSERT_EQ(send(strobe::Strobe{2, 20'000}), StatusCode::ok);
  std::this_thread::sleep_for(35ms);  // the strobe has ended, the watchdog not yet tripped
  EXPECT_TRUE(firmware.channels_on().empty());
  EXPECT_EQ(offs.load(), 1);
  ASSERT_EQ(send(strobe::ChannelOn{1}), StatusCode::ok);
  const auto deadline = Clock::now() + 2s;
  while (!firmware.channels_on().empty() && Clock::now() < deadline) {
    std::this_thread::sleep_for(5ms);
  }
  EXPECT_TRUE(firmware.channels_on().empty());
  EXPECT_TRUE(firmware.status().faults & fault::watchdog);
  firmware.stop_timer();
}

}  // namespace
}  // namespace psrig::lights
