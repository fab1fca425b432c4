#include "psrig/lights/usb_lights.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <exception>
#include <libusb.h>
#include <utility>
#include <vector>

#include "usb_enumeration.h"

namespace psrig::lights {
namespace {

using strobe::Opcode;
using strobe::StatusCode;

// Answers to earlier commands (late, after a timeout) dropped before giving up.
constexpr int max_stale_answers = 4;

std::string hex4(std::uint16_t value) {
  char text[8];
  std::snprintf(text, sizeof text, "%04x", value);
  return text;
}

std::string hex_endpoint(std::uint8_t endpoint) {
  char text[8];
  std::snprintf(text, sizeof text, "0x%02x", endpoint);
  return text;
}

std::string vid_pid(const config::UsbLights& usb) {
  return hex4(usb.vendor_id) + ":" + hex4(usb.product_id);
}

std::string wanted(const config::UsbLights& usb) {
  return "usb strobe controller " + vid_pid(usb) +
         (usb.serial.empty() ? "" : " with serial \"" + usb.serial + "\"");
}

std::string node_of(const MatchingUsbDevice& device) {
  char path[40];
  std::snprintf(path, sizeof path, "/dev/bus/usb/%03u/%03u", device.bus, device.address);
  return path;
}

std::string udev_rule(const config::UsbLights& usb) {
  return "SUBSYSTEM==\"usb\", ATTR{idVendor}==\"" + hex4(usb.vendor_id) +
         "\", ATTR{idProduct}==\"" + hex4(usb.product_id) +
         "\", MODE=\"0660\", GROUP=\"plugdev\", TAG+=\"uaccess\"";
}

// A failure of the controller or of its link: the device node (bus and
// address) as the file, the configuration section as the key.
Error device_error(std::string node, std::string message) {
  return {ErrorKind::io, std::move(message), std::move(node), "lights.usb"};
}

Error not_found(const config::UsbLights& usb, const std::string& detail) {
  return {ErrorKind::io,
          "no " + wanted(usb) + " found" + (detail.empty() ? "" : " (" + detail + ")") +
              ": check its USB cable and the udev rule for " + vid_pid(usb) +
              " (lights/PROTOCOL.md), and run `psrig devices` to list the controllers "
              "found",
          {},
          "lights.usb"};
}

Status known_channel(int channel, int channels) {
  if (channel >= 0 && channel < channels) return {};
  return std::unexpected(bad_input(
      {}, "lights.channels",
      "no channel " + std::to_string(channel) + " (" + std::to_string(channels) + " configured)"));
}

// Device code never throws: whatever escapes becomes an error here.
template <class F>
auto guarded(const char* what, F f) -> decltype(f()) {
  try {
    return f();
  } catch (const std::exception& e) {
    return std::unexpected(internal_error(std::string(what) + ": " + e.what()));
  } catch (...) {
    return std::unexpected(internal_error(std::string(what) + ": unknown exception"));
  }
}

}  // namespace

UsbStrobeLights::UsbStrobeLights(const config::LightsConfig& config, libusb_context* context,
                                 libusb_device_handle* handle, std::string node, std::string serial)
    : usb_(config.usb),
      channels_(config.channels),
      intensity_(config.intensity),
      context_(context),
      handle_(handle),
      node_(std::move(node)),
      serial_(std::move(serial)) {}

UsbStrobeLights::~UsbStrobeLights() {
  try {
    {
      const std::scoped_lock beat(beat_mutex_);
      stopping_ = true;
    }
    beat_wake_.notify_all();
    if (heartbeat_.joinable()) heartbeat_.join();
    std::unique_lock link(link_);
    if (!broken_) {
      if (auto off = exchange(link, strobe::AllOff{}); off && off->status == StatusCode::ok) {
        record_all_off();
      }
    }
  } catch (...) {  // best effort: the controller's watchdog turns everything off anyway
  }
  libusb_release_interface(handle_, strobe::interface_number);
  libusb_close(handle_);
  libusb_exit(context_);
}

std::string UsbStrobeLights::name() const {
  return "usb strobe controller " + vid_pid(usb_) + (serial_.empty() ? "" : " serial " + serial_);
}

std::string UsbStrobeLights::describe() const {
  const auto& f = info_.firmware;
  return name() + ", firmware " + std::to_string(f.major) + "." + std::to_string(f.minor) + "." +
         std::to_string(f.patch) + " (protocol " + std::to_string(info_.protocol_major) + "." +
         std::to_string(info_.protocol_minor) + ", " + std::to_string(info_.channels) +
         " channels) on " + node_;
}

void UsbStrobeLights::record_on(int channel) {
  if (logged_on_ >= 0 && logged_on_ != channel) log_.record(logged_on_, false);  // break first
  log_.record(channel, true);
  logged_on_ = channel;
}

void UsbStrobeLights::record_all_off() {
  log_.record(-1, false);
  logged_on_ = -1;
  strobe_channel_ = -1;
}

Status UsbStrobeLights::handshake() {
  std::unique_lock link(link_);
  const auto info = command(link, strobe::GetInfo{}, "tell its version");
  if (!info) return std::unexpected(info.error());
  info_ = std::get<strobe::DeviceInfo>(info->result);
  if (info_.protocol_major != strobe::protocol_major) {
    return std::unexpected(device_error(
        node_, name() + " speaks protocol " + std::to_string(info_.protocol_major) + "." +
                   std::to_string(info_.protocol_minor) + ", this psrig speaks " +
                   std::to_string(strobe::protocol_major) +
                   ".x: update the controller's firmware (or psrig) so that they match"));
  }
  if (info_.channels < channels_) {
    return std::unexpected(bad_input({}, "lights.channels",
                                     std::to_string(channels_) + " channels configured but " +
                                         name() + " drives " + std::to_string(info_.channels)));
  }
  // Faults latched before we came (a previous host's watchdog, say) are
  // history; one whose cause persists stops us here.
  const auto cleared = command(link, strobe::ClearFaults{strobe::fault::all}, "clear its faults");
  if (!cleared) return std::unexpected(cleared.error());
  if (const std::uint16_t left = std::get<strobe::FaultsReply>(cleared->result).faults;
      left & strobe::fault::blocking) {
    return std::unexpected(
        refused(link, Opcode::clear_faults, "clear its faults", StatusCode::faulted));
  }
  if (usb_.watchdog_ms < info_.watchdog_min_ms || usb_.watchdog_ms > info_.watchdog_max_ms) {
    return std::unexpected(bad_input({}, "lights.usb.watchdog_ms",
                                     std::to_string(usb_.watchdog_ms) + " ms is outside what " +
                                         name() + " accepts (" +
                                         std::to_string(info_.watchdog_min_ms) + " to " +
                                         std::to_string(info_.watchdog_max_ms) + " ms)"));
  }
  const auto watchdog = command(
      link, strobe::SetWatchdog{static_cast<std::uint16_t>(usb_.watchdog_ms)}, "set its watchdog");
  if (!watchdog) return std::unexpected(watchdog.error());
  for (int channel = 0; channel < channels_; ++channel) {
    const double level = channel < static_cast<int>(intensity_.size())
                             ? intensity_[static_cast<std::size_t>(channel)]
                             : 1.0;
    if (auto sent = send_intensity(link, channel, level); !sent) return sent;
  }
  const auto off = command(link, strobe::AllOff{}, "turn everything off");
  if (!off) return std::unexpected(off.error());
  record_all_off();
  link.unlock();

  heartbeat_ = std::thread([this] { heartbeat_loop(); });
  return {};
}

Result<strobe::Response> UsbStrobeLights::command(std::unique_lock<std::mutex>& link,
                                                  const strobe::Request& request,
                                                  const std::string& what) {
  auto response = exchange(link, request);
  if (!response || response->status == StatusCode::ok) return response;
  return std::unexpected(refused(link, opcode_of(request), what, response->status));
}

Result<strobe::Response> UsbStrobeLights::exchange(std::unique_lock<std::mutex>& link,
                                                   const strobe::Request& request) {
  if (broken_) return std::unexpected(*broken_);
  if (strobe_channel_ >= 0 && Clock::now() >= strobe_end_) {  // a strobe that has ended
    log_.record(strobe_channel_, false);
    logged_on_ = strobe_channel_ = -1;
  }
  const Opcode opcode = opcode_of(request);
  const bool repeatable = opcode != Opcode::strobe;  // every other command is idempotent
  for (int attempt = 0;; ++attempt) {
    const strobe::Command sent{seq_++, request};
    strobe::Frame frame = encode(sent);
    int moved = 0;
    int code = libusb_bulk_transfer(handle_, strobe::endpoint_out, frame.data(),
                                    static_cast<int>(frame.size()), &moved, usb_.timeout_ms);
    if (code == LIBUSB_ERROR_PIPE) {
      // A stalled OUT packet was not taken: clear the halt and repeat.
      libusb_clear_halt(handle_, strobe::endpoint_out);
      if (attempt == 0 && repeatable) continue;
      return std::unexpected(break_link(
          link, transport_message(opcode, code, strobe::endpoint_out, attempt > 0), false));
    }
    if (code == 0 && moved != static_cast<int>(frame.size())) code = LIBUSB_ERROR_IO;
    if (code < 0) {
      return std::unexpected(
          break_link(link, transport_message(opcode, code, strobe::endpoint_out, false),
                     code == LIBUSB_ERROR_NO_DEVICE));
    }
    bool repeat = false;
    for (int stale = 0; stale <= max_stale_answers && !repeat; ++stale) {
      std::array<std::uint8_t, strobe::max_frame_size> buffer{};
      code = libusb_bulk_transfer(handle_, strobe::endpoint_in, buffer.data(),
                                  static_cast<int>(buffer.size()), &moved, usb_.timeout_ms);
      if (code == LIBUSB_ERROR_PIPE) {
        // The command may have run; it is idempotent, so run it again
        // under a new seq (the old answer, if it comes, is dropped).
        libusb_clear_halt(handle_, strobe::endpoint_in);
        if (attempt == 0 && repeatable) {
          repeat = true;
          continue;
        }
        return std::unexpected(break_link(
            link, transport_message(opcode, code, strobe::endpoint_in, attempt > 0), false));
      }
      if (code < 0) {
        return std::unexpected(
            break_link(link, transport_message(opcode, code, strobe::endpoint_in, false),
                       code == LIBUSB_ERROR_NO_DEVICE));
      }
      auto response = strobe::decode_response(
          std::span<const std::uint8_t>(buffer.data(), static_cast<std::size_t>(moved)));
      if (!response) {
        return std::unexpected(break_link(link,
                                          name() + " sent a malformed answer to " +
                                              to_string(opcode) + ": " + response.error() +
                                              "; firmware and psrig disagree on PROTOCOL.md",
                                          false));
      }
      if (response->seq != sent.seq || response->opcode != opcode) continue;  // a late answer
      notice_offs(*response);
      return *response;
    }
    if (!repeat) {
      return std::unexpected(break_link(
          link,
          name() + " answered " + to_string(opcode) + " only with answers to earlier commands",
          false));
    }
  }
}

std::string UsbStrobeLights::transport_message(Opcode opcode, int code, std::uint8_t endpoint,
                                               bool stalled_twice) const {
  const std::string op = to_string(opcode);
  switch (code) {
    case LIBUSB_ERROR_NO_DEVICE:
      return name() + " is gone (unplugged or reset) during " + op +
             ": check its USB cable, then `psrig devices`; a controller that loses USB turns "
             "every LED off";
    case LIBUSB_ERROR_TIMEOUT:
      return name() + " did not answer " + op + " within " + std::to_string(usb_.timeout_ms) +
             " ms (lights.usb.timeout_ms): check the cable, or unplug and replug the controller";
    case LIBUSB_ERROR_PIPE:
      return name() + ": endpoint " + hex_endpoint(endpoint) + " stalled during " + op +
             (stalled_twice ? " again after its halt was cleared" : "") +
             "; unplug and replug the controller if it persists";
    default:
      return name() + ": USB transfer on endpoint " + hex_endpoint(endpoint) + " for " + op +
             " failed: " + libusb_strerror(code);
  }
}

Error UsbStrobeLights::break_link(std::unique_lock<std::mutex>& link, const std::string& message,
                                  bool device_gone) {
  (void)link;  // held by the caller's exchange
  std::string text = message;
  if (!device_gone) {
    // One plain ALL_OFF, no repeats; if it does not get through, the
    // watchdog (no longer fed) does the job.
    const strobe::Command off{seq_++, strobe::AllOff{}};
    strobe::Frame frame = encode(off);
    int moved = 0;
    bool done = false;
    if (libusb_bulk_transfer(handle_, strobe::endpoint_out, frame.data(),
                             static_cast<int>(frame.size()), &moved, usb_.timeout_ms) == 0) {
      for (int stale = 0; stale <= max_stale_answers && !done; ++stale) {
        std::array<std::uint8_t, strobe::max_frame_size> buffer{};
        if (libusb_bulk_transfer(handle_, strobe::endpoint_in, buffer.data(),
                                 static_cast<int>(buffer.size()), &moved, usb_.timeout_ms) != 0) {
          break;
        }
        const auto answer = strobe::decode_response(
            std::span<const std::uint8_t>(buffer.data(), static_cast<std::size_t>(moved)));
        if (!answer) break;
        done = answer->seq == off.seq && answer->opcode == Opcode::all_off &&
               answer->status == StatusCode::ok;
      }
    }
    if (done) {
      record_all_off();
      text += "; every LED is off";
    } else {
      text += "; the controller's watchdog turns every LED off within " +
              std::to_string(usb_.watchdog_ms) + " ms";
    }
  }
  text += "; open the lights again to go on";
  broken_ = device_error(node_, text);
  return *broken_;
}

Error UsbStrobeLights::refused(std::unique_lock<std::mutex>& link, Opcode opcode,
                               const std::string& what, StatusCode status) {
  if (status != StatusCode::faulted) {
    return device_error(node_, name() + " refused to " + what + " (" + to_string(opcode) + ": " +
                                   to_string(status) +
                                   "): psrig and its firmware disagree on PROTOCOL.md");
  }
  std::string text = name() + " refuses to " + what + ": fault latched";
  const auto status_reply = exchange(link, strobe::GetStatus{});
  if (!status_reply || status_reply->status != StatusCode::ok) return device_error(node_, text);
  const auto& s = std::get<strobe::DeviceStatus>(status_reply->result);
  text += ": " + strobe::describe_faults(s.faults);
  if (s.faults & strobe::fault::watchdog) {
    text += " (psrig fell silent for longer than lights.usb.watchdog_ms = " +
            std::to_string(usb_.watchdog_ms) + " ms)";
  }
  if (s.faults & (strobe::fault::led_open | strobe::fault::led_short)) {
    text += "; check the LED wiring of channel(s)";
    for (int channel = 0; channel < 8; ++channel) {
      if (s.led_fault_channels & (1u << channel)) text += " " + std::to_string(channel);
    }
  }
  if ((s.faults & strobe::fault::over_temperature) &&
      s.temperature_decidegrees != strobe::no_temperature) {
    char temperature[32];
    std::snprintf(temperature, sizeof temperature, "%.1f", s.temperature_decidegrees / 10.0);
    text += "; the driver is at " + std::string(temperature) + " °C, let it cool";
  }
  text += "; clear_faults() (or opening the lights again) clears it";
  return device_error(node_, text);
}

void UsbStrobeLights::notice_offs(const strobe::Response& response) {
  std::uint8_t on = strobe::no_channel;
  if (const auto* beat = std::get_if<strobe::HeartbeatReply>(&response.result)) {
    on = beat->on_channel;
  } else if (const auto* status = std::get_if<strobe::DeviceStatus>(&response.result)) {
    on = status->on_channel;
  } else {
    return;
  }
  // The controller switched off by itself (strobe ended, watchdog, fault).
  if (on == strobe::no_channel && logged_on_ >= 0) record_all_off();
}

Status UsbStrobeLights::turn_on(int channel) {
  return guarded("usb lights: turn_on", [&]() -> Status {
    if (auto known = known_channel(channel, channels_); !known) return known;
    std::unique_lock link(link_);
    const auto on = command(link, strobe::ChannelOn{static_cast<std::uint8_t>(channel)},
                            "turn channel " + std::to_string(channel) + " on");
    if (!on) return std::unexpected(on.error());
    strobe_channel_ = -1;
    record_on(channel);
    return {};
  });
}

Status UsbStrobeLights::strobe(int channel, std::chrono::microseconds duration) {
  return guarded("usb lights: strobe", [&]() -> Status {
    if (auto known = known_channel(channel, channels_); !known) return known;
    if (duration.count() < 1 || duration.count() > info_.strobe_max_us) {
      return std::unexpected(bad_input({}, {},
                                       "a strobe lasts 1 to " +
                                           std::to_string(info_.strobe_max_us) + " us on " +
                                           name() + ", not " + std::to_string(duration.count())));
    }
    std::unique_lock link(link_);
    const Clock::time_point sent = Clock::now();
    const auto on = command(link,
                            strobe::Strobe{static_cast<std::uint8_t>(channel),
                                           static_cast<std::uint32_t>(duration.count())},
                            "strobe channel " + std::to_string(channel));
    if (!on) return std::unexpected(on.error());
    record_on(channel);
    strobe_channel_ = channel;
    strobe_end_ = sent + duration;
    return {};
  });
}

Status UsbStrobeLights::all_off() {
  return guarded("usb lights: all_off", [&]() -> Status {
    std::unique_lock link(link_);
    const auto off = command(link, strobe::AllOff{}, "turn everything off");
    if (!off) return std::unexpected(off.error());
    record_all_off();
    return {};
  });
}

Status UsbStrobeLights::set_intensity(int channel, double level) {
  return guarded("usb lights: set_intensity", [&]() -> Status {
    if (auto known = known_channel(channel, channels_); !known) return known;
    std::unique_lock link(link_);
    return send_intensity(link, channel, level);
  });
}

Status UsbStrobeLights::send_intensity(std::unique_lock<std::mutex>& link, int channel,
                                       double level) {
  if (!std::isfinite(level) || level < 0 || level > 1) {
    return std::unexpected(bad_input({}, "lights.intensity",
                                     "channel " + std::to_string(channel) + ": " +
                                         std::to_string(level) + " is not within 0 to 1"));
  }
  const auto set =
      command(link,
              strobe::SetIntensity{
                  static_cast<std::uint8_t>(channel),
                  static_cast<std::uint16_t>(std::lround(level * strobe::intensity_full_scale))},
              "set channel " + std::to_string(channel) + "'s intensity");
  if (!set) return std::unexpected(set.error());
  return {};
}

Result<strobe::DeviceStatus> UsbStrobeLights::read_status() {
  return guarded("usb lights: read_status", [&]() -> Result<strobe::DeviceStatus> {
    std::unique_lock link(link_);
    const auto status = command(link, strobe::GetStatus{}, "report its status");
    if (!status) return std::unexpected(status.error());
    return std::get<strobe::DeviceStatus>(status->result);
  });
}

Result<std::uint16_t> UsbStrobeLights::clear_faults() {
  return guarded("usb lights: clear_faults", [&]() -> Result<std::uint16_t> {
    std::unique_lock link(link_);
    const auto cleared = command(link, strobe::ClearFaults{strobe::fault::all}, "clear its faults");
    if (!cleared) return std::unexpected(cleared.error());
    return std::get<strobe::FaultsReply>(cleared->result).faults;
  });
}

void UsbStrobeLights::hold_heartbeat(bool held) {
  {
    const std::scoped_lock beat(beat_mutex_);
    held_ = held;
  }
  beat_wake_.notify_all();
}

void UsbStrobeLights::heartbeat_loop() {
  try {
    // A quarter of the timeout: three beats may go missing before it trips.
    const auto period = std::chrono::milliseconds(std::max(1, usb_.watchdog_ms / 4));
    std::unique_lock beat(beat_mutex_);
    while (!stopping_) {
      beat_wake_.wait_for(beat, period, [this] { return stopping_; });
      if (stopping_) break;
      if (held_) continue;
      beat.unlock();
      bool alive = false;
      {
        std::unique_lock link(link_);
        alive = exchange(link, strobe::Heartbeat{}).has_value();
      }
      beat.lock();
      if (!alive) break;  // the link is broken: let the watchdog trip
    }
  } catch (...) {  // no heartbeat: the controller turns everything off by itself
  }
}

Result<std::unique_ptr<UsbStrobeLights>> open_usb_strobe(const config::LightsConfig& config) {
  return guarded("usb lights: open", [&]() -> Result<std::unique_ptr<UsbStrobeLights>> {
    const config::UsbLights& usb = config.usb;
    if (config.channels < 1 || config.channels > 8) {
      return std::unexpected(bad_input({}, "lights.channels",
                                       "the usb strobe controller drives 1 to 8 channels, not " +
                                           std::to_string(config.channels)));
    }
    if (usb.timeout_ms < 1) {
      return std::unexpected(bad_input({}, "lights.usb.timeout_ms", "must be at least 1 ms"));
    }
    if (usb.watchdog_ms < 1 || usb.watchdog_ms > 65535) {
      return std::unexpected(bad_input({}, "lights.usb.watchdog_ms", "must be 1 to 65535 ms"));
    }

    auto context = start_libusb();
    if (!context) {
      return std::unexpected(not_found(usb, std::string("libusb cannot start: ") +
                                                libusb_strerror(context.error()) +
                                                "; is there USB on this machine?"));
    }
    auto devices = open_usb_devices(context->get(), usb.vendor_id, usb.product_id);
    if (!devices) {
      return std::unexpected(not_found(
          usb, std::string("cannot list USB devices: ") + libusb_strerror(devices.error())));
    }

    std::vector<MatchingUsbDevice> matches;
    std::vector<std::string> others;  // controllers with another serial
    std::optional<Error> open_error;
    for (MatchingUsbDevice& device : *devices) {
      const std::string node = node_of(device);
      if (!device.handle) {
        if (device.open_error == LIBUSB_ERROR_ACCESS) {
          open_error = device_error(
              node, "permission denied opening the usb strobe controller " + vid_pid(usb) +
                        ": install the udev rule (lights/PROTOCOL.md) as "
                        "/etc/udev/rules.d/70-psrig.rules: " +
                        udev_rule(usb) +
                        ", then `udevadm control --reload && udevadm trigger` (or replug) and "
                        "make sure the user is in group plugdev");
        } else {
          open_error = device_error(node, "cannot open the usb strobe controller " + vid_pid(usb) +
                                              ": " + libusb_strerror(device.open_error));
        }
        continue;
      }
      if (!usb.serial.empty() && device.serial != usb.serial) {
        others.push_back((device.serial.empty() ? "no serial" : "serial " + device.serial) +
                         " on " + node);
        continue;  // its handle closes with `devices`
      }
      matches.push_back(std::move(device));
    }
    devices->clear();
    if (matches.empty()) {
      if (open_error) return std::unexpected(*open_error);
      std::string detail;
      for (const std::string& other : others)
        detail += (detail.empty() ? "" : ", ") + other;
      return std::unexpected(not_found(usb, detail.empty() ? "" : "found only " + detail));
    }
    if (matches.size() > 1) {
      std::string found;
      for (const MatchingUsbDevice& match : matches) {
        found += (found.empty() ? "" : ", ") + (match.serial.empty() ? "no serial" : match.serial) +
                 " on " + node_of(match);
      }
      return std::unexpected(bad_input({}, "lights.usb.serial",
                                       std::to_string(matches.size()) + " usb strobe controllers " +
                                           vid_pid(usb) + " found (" + found +
                                           "): set lights.usb.serial to the one to use"));
    }
    MatchingUsbDevice match = std::move(matches.front());
    matches.clear();
    const std::string node = node_of(match);
    // On failure the handle closes before the context exits (declared after it).
    if (const int code = libusb_claim_interface(match.handle.get(), strobe::interface_number);
        code < 0) {
      return std::unexpected(device_error(
          node,
          "cannot claim the usb strobe controller " + vid_pid(usb) +
              (match.serial.empty() ? "" : " serial " + match.serial) + ": " +
              libusb_strerror(code) +
              (code == LIBUSB_ERROR_BUSY ? " (another program has it: is psrigd already running?)"
                                         : "")));
    }
    // The lights take the context with them on failure.
    std::unique_ptr<UsbStrobeLights> lights(new UsbStrobeLights(
        config, context->release(), match.handle.release(), node, match.serial));
    if (auto ready = lights->handshake(); !ready) return std::unexpected(ready.error());
    return lights;
  });
}

Result<std::unique_ptr<LightController>> open_usb_lights(const config::LightsConfig& config) {
  auto lights = open_usb_strobe(config);
  if (!lights) return std::unexpected(lights.error());
  return std::unique_ptr<LightController>(std::move(*lights));
}

}  // namespace psrig::lights
