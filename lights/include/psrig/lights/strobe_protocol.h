#pragma once
// The USB strobe controller's wire protocol (lights/PROTOCOL.md):
// frames to and from bytes, pure functions shared by the host backend and
// the simulated firmware so that both speak exactly the same bytes.

#include <cstdint>
#include <expected>
#include <span>
#include <string>
#include <variant>
#include <vector>

namespace psrig::lights::strobe {

inline constexpr std::uint8_t command_magic = 0x50;   // 'P', host to device
inline constexpr std::uint8_t response_magic = 0x70;  // 'p', device to host
inline constexpr std::size_t header_size = 4;
inline constexpr std::size_t max_frame_size = 64;  // one full-speed bulk packet
inline constexpr std::uint8_t protocol_major = 1;
inline constexpr std::uint8_t protocol_minor = 0;
inline constexpr std::uint8_t no_channel = 0xFF;  // on_channel when all are off
inline constexpr std::uint16_t intensity_full_scale = 1000;
inline constexpr std::int16_t no_temperature = INT16_MIN;

// Endpoints and interface of the controller.
inline constexpr std::uint8_t endpoint_out = 0x01;
inline constexpr std::uint8_t endpoint_in = 0x81;
inline constexpr int interface_number = 0;

enum class Opcode : std::uint8_t {
  get_info = 0x01,
  get_status = 0x02,
  heartbeat = 0x03,
  set_watchdog = 0x04,
  clear_faults = 0x05,
  channel_on = 0x10,
  all_off = 0x11,
  set_intensity = 0x12,
  strobe = 0x13,
};

enum class StatusCode : std::uint8_t {
  ok = 0,
  bad_frame = 1,
  unknown_opcode = 2,
  bad_length = 3,
  bad_argument = 4,
  faulted = 5,
};

// Latched fault flags.
namespace fault {
inline constexpr std::uint16_t watchdog = 1u << 0;
inline constexpr std::uint16_t over_temperature = 1u << 1;
inline constexpr std::uint16_t led_open = 1u << 2;
inline constexpr std::uint16_t led_short = 1u << 3;
inline constexpr std::uint16_t bad_command = 1u << 4;
inline constexpr std::uint16_t all = 0xFFFF;
// Latched faults that make the firmware refuse CHANNEL_ON and STROBE
// (unknown bits count: a newer firmware's fault is taken seriously).
inline constexpr std::uint16_t blocking = static_cast<std::uint16_t>(~bad_command);
}  // namespace fault

// Commands.
struct GetInfo {};
struct GetStatus {};
struct Heartbeat {};
struct SetWatchdog {
  std::uint16_t timeout_ms = 0;
};
struct ClearFaults {
  std::uint16_t mask = 0;
};
struct ChannelOn {
  std::uint8_t channel = 0;
};
struct AllOff {};
struct SetIntensity {
  std::uint8_t channel = 0;
  std::uint16_t permille = 0;
};
struct Strobe {
  std::uint8_t channel = 0;
  std::uint32_t duration_us = 0;
};
using Request = std::variant<GetInfo, GetStatus, Heartbeat, SetWatchdog, ClearFaults, ChannelOn,
                             AllOff, SetIntensity, Strobe>;

struct Command {
  std::uint8_t seq = 0;
  Request request;
};

// Results, one per command that returns something.
struct Version {
  std::uint8_t major = 0, minor = 0, patch = 0;
  friend bool operator==(const Version&, const Version&) = default;
};
struct DeviceInfo {
  std::uint8_t protocol_major = 0;
  std::uint8_t protocol_minor = 0;
  Version firmware;
  std::uint8_t channels = 0;
  std::uint16_t intensity_full_scale = 0;
  std::uint16_t watchdog_min_ms = 0;
  std::uint16_t watchdog_max_ms = 0;
  std::uint32_t strobe_max_us = 0;
  friend bool operator==(const DeviceInfo&, const DeviceInfo&) = default;
};
struct DeviceStatus {
  std::uint16_t faults = 0;
  std::uint8_t on_channel = no_channel;
  bool strobing = false;
  bool watchdog_armed = false;
  std::uint8_t led_fault_channels = 0;
  std::int16_t temperature_decidegrees = no_temperature;
  std::uint16_t watchdog_ms = 0;
  friend bool operator==(const DeviceStatus&, const DeviceStatus&) = default;
};
struct HeartbeatReply {
  std::uint16_t faults = 0;
  std::uint8_t on_channel = no_channel;
  friend bool operator==(const HeartbeatReply&, const HeartbeatReply&) = default;
};
struct FaultsReply {  // CLEAR_FAULTS: what is still latched
  std::uint16_t faults = 0;
  friend bool operator==(const FaultsReply&, const FaultsReply&) = default;
};
using Result = std::variant<std::monostate, DeviceInfo, DeviceStatus, HeartbeatReply, FaultsReply>;

struct Response {
  Opcode opcode = Opcode::get_info;  // raw byte when the command's opcode was unknown
  std::uint8_t seq = 0;
  StatusCode status = StatusCode::ok;
  Result result;  // monostate unless status is ok and the opcode returns something
};

using Frame = std::vector<std::uint8_t>;

[[nodiscard]] Opcode opcode_of(const Request& request);
[[nodiscard]] Frame encode(const Command& command);
[[nodiscard]] Frame encode(const Response& response);

// Why a frame was rejected, with what the answer should echo.
struct Rejection {
  StatusCode status = StatusCode::bad_frame;
  std::uint8_t opcode = 0;  // as received (0 if the frame was too short to hold one)
  std::uint8_t seq = 0;
  std::string reason;
};

// A command as the firmware receives it. Checks the frame, not the
// arguments' ranges (those depend on the device: the firmware checks them).
[[nodiscard]] std::expected<Command, Rejection> decode_command(std::span<const std::uint8_t> bytes);
// A response as the host receives it. Results may be longer than this
// version knows (newer minor versions append fields); never shorter.
[[nodiscard]] std::expected<Response, std::string> decode_response(
    std::span<const std::uint8_t> bytes);

[[nodiscard]] std::string to_string(Opcode opcode);
[[nodiscard]] std::string to_string(StatusCode status);
// "watchdog tripped, LED open" for the flags set; "none" when none is.
[[nodiscard]] std::string describe_faults(std::uint16_t faults);

}  // namespace psrig::lights::strobe
