#include "psrig/lights/strobe_protocol.h"

#include <array>
#include <cstdio>
#include <utility>

namespace psrig::lights::strobe {
namespace {

// Little-endian fields, written and read byte by byte: the host's order
// never matters.
class Writer {
 public:
  void u8(std::uint8_t value) { bytes_.push_back(value); }
  void u16(std::uint16_t value) {
    u8(static_cast<std::uint8_t>(value & 0xFF));
    u8(static_cast<std::uint8_t>(value >> 8));
  }
  void i16(std::int16_t value) { u16(static_cast<std::uint16_t>(value)); }
  void u32(std::uint32_t value) {
    u16(static_cast<std::uint16_t>(value & 0xFFFF));
    u16(static_cast<std::uint16_t>(value >> 16));
  }
  // The header goes in front of the payload written so far.
  [[nodiscard]] Frame frame(std::uint8_t magic, std::uint8_t opcode, std::uint8_t seq) && {
    bytes_[0] = magic;
    bytes_[1] = opcode;
    bytes_[2] = seq;
    bytes_[3] = static_cast<std::uint8_t>(bytes_.size() - header_size);
    return std::move(bytes_);
  }

 private:
  Frame bytes_ = Frame(header_size);
};

class Reader {
 public:
  explicit Reader(std::span<const std::uint8_t> bytes) : bytes_(bytes) {}
  [[nodiscard]] std::size_t left() const { return bytes_.size() - at_; }
  std::uint8_t u8() { return bytes_[at_++]; }
  std::uint16_t u16() {
    const std::uint16_t low = u8();
    return static_cast<std::uint16_t>(low | (u8() << 8));
  }
  std::int16_t i16() { return static_cast<std::int16_t>(u16()); }
  std::uint32_t u32() {
    const std::uint32_t low = u16();
    return low | (static_cast<std::uint32_t>(u16()) << 16);
  }

 private:
  std::span<const std::uint8_t> bytes_;
  std::size_t at_ = 0;
};

// Payload length of each command, and whether the opcode is known.
constexpr int command_payload(std::uint8_t opcode) {
  switch (static_cast<Opcode>(opcode)) {
    case Opcode::get_info:
    case Opcode::get_status:
    case Opcode::heartbeat:
    case Opcode::all_off:
      return 0;
    case Opcode::set_watchdog:
    case Opcode::clear_faults:
      return 2;
    case Opcode::channel_on:
      return 1;
    case Opcode::set_intensity:
      return 3;
    case Opcode::strobe:
      return 5;
  }
  return -1;
}

// Result length for a successful response, in this version.
constexpr std::size_t info_size = 16;
constexpr std::size_t status_size = 10;
constexpr std::size_t heartbeat_size = 3;
constexpr std::size_t faults_size = 2;

std::string hex(unsigned value) {
  char text[8];
  std::snprintf(text, sizeof text, "0x%02X", value);
  return text;
}

}  // namespace

Opcode opcode_of(const Request& request) {
  struct Visitor {
    Opcode operator()(const GetInfo&) const { return Opcode::get_info; }
    Opcode operator()(const GetStatus&) const { return Opcode::get_status; }
    Opcode operator()(const Heartbeat&) const { return Opcode::heartbeat; }
    Opcode operator()(const SetWatchdog&) const { return Opcode::set_watchdog; }
    Opcode operator()(const ClearFaults&) const { return Opcode::clear_faults; }
    Opcode operator()(const ChannelOn&) const { return Opcode::channel_on; }
    Opcode operator()(const AllOff&) const { return Opcode::all_off; }
    Opcode operator()(const SetIntensity&) const { return Opcode::set_intensity; }
    Opcode operator()(const Strobe&) const { return Opcode::strobe; }
  };
  return std::visit(Visitor{}, request);
}

Frame encode(const Command& command) {
  Writer w;
  if (const auto* r = std::get_if<SetWatchdog>(&command.request)) w.u16(r->timeout_ms);
  if (const auto* r = std::get_if<ClearFaults>(&command.request)) w.u16(r->mask);
  if (const auto* r = std::get_if<ChannelOn>(&command.request)) w.u8(r->channel);
  if (const auto* r = std::get_if<SetIntensity>(&command.request)) {
    w.u8(r->channel);
    w.u16(r->permille);
  }
  if (const auto* r = std::get_if<Strobe>(&command.request)) {
    w.u8(r->channel);
    w.u32(r->duration_us);
  }
  return std::move(w).frame(command_magic, std::to_underlying(opcode_of(command.request)),
                            command.seq);
}

Frame encode(const Response& response) {
  Writer w;
  w.u8(std::to_underlying(response.status));
  if (response.status == StatusCode::ok) {
    if (const auto* r = std::get_if<DeviceInfo>(&response.result)) {
      w.u8(r->protocol_major);
      w.u8(r->protocol_minor);
      w.u8(r->firmware.major);
      w.u8(r->firmware.minor);
      w.u8(r->firmware.patch);
      w.u8(r->channels);
      w.u16(r->intensity_full_scale);
      w.u16(r->watchdog_min_ms);
      w.u16(r->watchdog_max_ms);
      w.u32(r->strobe_max_us);
    } else if (const auto* s = std::get_if<DeviceStatus>(&response.result)) {
      w.u16(s->faults);
      w.u8(s->on_channel);
      w.u8(static_cast<std::uint8_t>((s->strobing ? 1 : 0) | (s->watchdog_armed ? 2 : 0)));
      w.u8(s->led_fault_channels);
      w.u8(0);
      w.i16(s->temperature_decidegrees);
      w.u16(s->watchdog_ms);
    } else if (const auto* h = std::get_if<HeartbeatReply>(&response.result)) {
      w.u16(h->faults);
      w.u8(h->on_channel);
    } else if (const auto* f = std::get_if<FaultsReply>(&response.result)) {
      w.u16(f->faults);
    }
  }
  return std::move(w).frame(response_magic, std::to_underlying(response.opcode), response.seq);
}

std::expected<Command, Rejection> decode_command(std::span<const std::uint8_t> bytes) {
  Rejection no{StatusCode::bad_frame, bytes.size() > 1 ? bytes[1] : std::uint8_t{0},
               bytes.size() > 2 ? bytes[2] : std::uint8_t{0}, ""};
  if (bytes.size() < header_size || bytes.size() > max_frame_size) {
    no.reason = "a frame is 4 to 64 bytes, got " + std::to_string(bytes.size());
    return std::unexpected(no);
  }
  if (bytes[0] != command_magic) {
    no.reason = "magic " + hex(bytes[0]) + ", expected " + hex(command_magic);
    return std::unexpected(no);
  }
  if (bytes.size() != header_size + bytes[3]) {
    no.reason = "length field " + std::to_string(bytes[3]) + " but " +
                std::to_string(bytes.size() - header_size) + " payload bytes";
    return std::unexpected(no);
  }
  const int expected = command_payload(bytes[1]);
  if (expected < 0) {
    no.status = StatusCode::unknown_opcode;
    no.reason = "unknown opcode " + hex(bytes[1]);
    return std::unexpected(no);
  }
  if (bytes[3] != expected) {
    no.status = StatusCode::bad_length;
    no.reason = to_string(static_cast<Opcode>(bytes[1])) + " takes " + std::to_string(expected) +
                " payload bytes, got " + std::to_string(bytes[3]);
    return std::unexpected(no);
  }
  Reader r(bytes.subspan(header_size));
  Command command{bytes[2], GetInfo{}};
  switch (static_cast<Opcode>(bytes[1])) {
    case Opcode::get_info:
      command.request = GetInfo{};
      break;
    case Opcode::get_status:
      command.request = GetStatus{};
      break;
    case Opcode::heartbeat:
      command.request = Heartbeat{};
      break;
    case Opcode::all_off:
      command.request = AllOff{};
      break;
    case Opcode::set_watchdog:
      command.request = SetWatchdog{r.u16()};
      break;
    case Opcode::clear_faults:
      command.request = ClearFaults{r.u16()};
      break;
    case Opcode::channel_on:
      command.request = ChannelOn{r.u8()};
      break;
    case Opcode::set_intensity: {
      const std::uint8_t channel = r.u8();
      command.request = SetIntensity{channel, r.u16()};
      break;
    }
    case Opcode::strobe: {
      const std::uint8_t channel = r.u8();
      command.request = Strobe{channel, r.u32()};
      break;
    }
  }
  return command;
}

std::expected<Response, std::string> decode_response(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < header_size + 1 || bytes.size() > max_frame_size) {
    return std::unexpected("a response is 5 to 64 bytes, got " + std::to_string(bytes.size()));
  }
  if (bytes[0] != response_magic) {
    return std::unexpected("magic " + hex(bytes[0]) + ", expected " + hex(response_magic));
  }
  if (bytes.size() != header_size + bytes[3]) {
    return std::unexpected("length field " + std::to_string(bytes[3]) + " but " +
                           std::to_string(bytes.size() - header_size) + " payload bytes");
  }
  Response response;
  response.opcode = static_cast<Opcode>(bytes[1]);
  response.seq = bytes[2];
  const std::uint8_t status = bytes[4];
  if (status > std::to_underlying(StatusCode::faulted)) {
    return std::unexpected("unknown status code " + std::to_string(status));
  }
  response.status = static_cast<StatusCode>(status);
  if (response.status != StatusCode::ok) return response;  // a refusal carries nothing more

  Reader r(bytes.subspan(header_size + 1));
  const auto need = [&](std::size_t size) -> std::expected<void, std::string> {
    if (r.left() >= size) return {};
    return std::unexpected(to_string(response.opcode) + " result needs " + std::to_string(size) +
                           " bytes, got " + std::to_string(r.left()));
  };
  switch (response.opcode) {
    case Opcode::get_info: {
      if (auto ok = need(info_size); !ok) return std::unexpected(ok.error());
      DeviceInfo info;
      info.protocol_major = r.u8();
      info.protocol_minor = r.u8();
      info.firmware.major = r.u8();
      info.firmware.minor = r.u8();
      info.firmware.patch = r.u8();
      info.channels = r.u8();
      info.intensity_full_scale = r.u16();
      info.watchdog_min_ms = r.u16();
      info.watchdog_max_ms = r.u16();
      info.strobe_max_us = r.u32();
      response.result = info;
      break;
    }
    case Opcode::get_status: {
      if (auto ok = need(status_size); !ok) return std::unexpected(ok.error());
      DeviceStatus s;
      s.faults = r.u16();
      s.on_channel = r.u8();
      const std::uint8_t flags = r.u8();
      s.strobing = (flags & 1) != 0;
      s.watchdog_armed = (flags & 2) != 0;
      s.led_fault_channels = r.u8();
      r.u8();  // reserved
      s.temperature_decidegrees = r.i16();
      s.watchdog_ms = r.u16();
      response.result = s;
      break;
    }
    case Opcode::heartbeat: {
      if (auto ok = need(heartbeat_size); !ok) return std::unexpected(ok.error());
      HeartbeatReply h;
      h.faults = r.u16();
      h.on_channel = r.u8();
      response.result = h;
      break;
    }
    case Opcode::clear_faults: {
      if (auto ok = need(faults_size); !ok) return std::unexpected(ok.error());
      response.result = FaultsReply{r.u16()};
      break;
    }
    default:
      break;  // the other commands return nothing
  }
  return response;
}

std::string to_string(Opcode opcode) {
  switch (opcode) {
    case Opcode::get_info:
      return "GET_INFO";
    case Opcode::get_status:
      return "GET_STATUS";
    case Opcode::heartbeat:
      return "HEARTBEAT";
    case Opcode::set_watchdog:
      return "SET_WATCHDOG";
    case Opcode::clear_faults:
      return "CLEAR_FAULTS";
    case Opcode::channel_on:
      return "CHANNEL_ON";
    case Opcode::all_off:
      return "ALL_OFF";
    case Opcode::set_intensity:
      return "SET_INTENSITY";
    case Opcode::strobe:
      return "STROBE";
  }
  return "opcode " + hex(std::to_underlying(opcode));
}

std::string to_string(StatusCode status) {
  switch (status) {
    case StatusCode::ok:
      return "ok";
    case StatusCode::bad_frame:
      return "bad frame";
    case StatusCode::unknown_opcode:
      return "unknown opcode";
    case StatusCode::bad_length:
      return "bad length";
    case StatusCode::bad_argument:
      return "bad argument";
    case StatusCode::faulted:
      return "refused: fault latched";
  }
  return "status " + std::to_string(std::to_underlying(status));
}

std::string describe_faults(std::uint16_t faults) {
  static constexpr std::array<std::pair<std::uint16_t, const char*>, 5> names{{
      {fault::watchdog, "watchdog tripped (no heartbeat in time)"},
      {fault::over_temperature, "over-temperature"},
      {fault::led_open, "LED open"},
      {fault::led_short, "LED short"},
      {fault::bad_command, "bad command received"},
  }};
  std::string text;
  std::uint16_t known = 0;
  for (const auto& [bit, name] : names) {
    known |= bit;
    if (faults & bit) text += (text.empty() ? "" : ", ") + std::string(name);
  }
  if (faults & ~known) {
    text += (text.empty() ? "" : ", ") + std::string("unknown fault bits ") +
            hex(static_cast<unsigned>(faults & ~known));
  }
  return text.empty() ? "none" : text;
}

}  // namespace psrig::lights::strobe
