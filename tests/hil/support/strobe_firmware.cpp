#include "strobe_firmware.h"

#include <algorithm>
#include <chrono>
#include <utility>

namespace psrig::test {

namespace strobe = lights::strobe;
using lights::Clock;
using lights::SwitchEvent;

namespace fault = strobe::fault;
using strobe::AllOff, strobe::ChannelOn, strobe::ClearFaults, strobe::Command, strobe::DeviceInfo,
    strobe::DeviceStatus, strobe::FaultsReply, strobe::Frame, strobe::GetInfo, strobe::GetStatus,
    strobe::Heartbeat, strobe::HeartbeatReply, strobe::Opcode, strobe::Request, strobe::Response,
    strobe::SetIntensity, strobe::SetWatchdog, strobe::StatusCode, strobe::Strobe;
using strobe::command_magic, strobe::decode_command, strobe::protocol_major, strobe::protocol_minor,
    strobe::header_size, strobe::intensity_full_scale, strobe::no_channel;

StrobeFirmware::StrobeFirmware(Options options, OnSwitch on_switch)
    : options_(options),
      on_switch_(std::move(on_switch)),
      outputs_(static_cast<std::size_t>(std::clamp(options.channels, 1, 8))),
      watchdog_ms_(options.default_watchdog_ms) {}

StrobeFirmware::~StrobeFirmware() {
  stop_timer();
}

void StrobeFirmware::start_timer() {
  const std::scoped_lock lock(mutex_);
  if (timer_.joinable()) return;
  stop_ = false;
  timer_ = std::thread([this] {
    std::unique_lock held(mutex_);
    while (!stop_) {
      if (const auto deadline = next_deadline_locked()) {
        wake_.wait_until(held, *deadline);
      } else {
        wake_.wait(held);
      }
      if (!stop_) advance_locked(Clock::now());
    }
  });
}

void StrobeFirmware::stop_timer() {
  {
    const std::scoped_lock lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (timer_.joinable()) timer_.join();
}

Frame StrobeFirmware::receive(std::span<const std::uint8_t> bytes, Clock::time_point now) {
  if (bytes.empty()) return {};
  Response response;
  {
    const std::scoped_lock lock(mutex_);
    now = std::max(now, latest_);
    advance_locked(now);  // timers that expired before this frame fire first
    // Any frame with a sound header shows a live host, whatever it asks.
    if (bytes.size() >= header_size && bytes[0] == command_magic &&
        bytes.size() == header_size + bytes[3]) {
      watchdog_armed_ = true;
      last_feed_ = now;
    }
    const auto command = decode_command(bytes);
    if (command) {
      response = execute(*command, now);
    } else {
      response.opcode = static_cast<Opcode>(command.error().opcode);
      response.seq = command.error().seq;
      response.status = command.error().status;
    }
    if (response.status == StatusCode::ok) {
      ++handled_[response.opcode];
    } else if (response.status != StatusCode::faulted) {
      latch(fault::bad_command, now);
    }
  }
  wake_.notify_all();
  return encode(response);
}

Response StrobeFirmware::execute(const Command& command, Clock::time_point now) {
  Response response{opcode_of(command.request), command.seq, StatusCode::ok, {}};
  const auto channel_ok = [&](std::uint8_t channel) { return channel < outputs_.size(); };
  const auto refuse = [&](StatusCode status) {
    response.status = status;
    return response;
  };
  const Request& r = command.request;
  if (std::holds_alternative<GetInfo>(r)) {
    response.result =
        DeviceInfo{protocol_major,           protocol_minor,
                   options_.firmware,        static_cast<std::uint8_t>(outputs_.size()),
                   intensity_full_scale,     options_.watchdog_min_ms,
                   options_.watchdog_max_ms, options_.strobe_max_us};
  } else if (std::holds_alternative<GetStatus>(r)) {
    response.result = status_locked();
  } else if (std::holds_alternative<Heartbeat>(r)) {
    response.result = HeartbeatReply{
        faults_, static_cast<std::uint8_t>(on_channel_ < 0 ? no_channel : on_channel_)};
  } else if (const auto* set = std::get_if<SetWatchdog>(&r)) {
    if (set->timeout_ms < options_.watchdog_min_ms || set->timeout_ms > options_.watchdog_max_ms) {
      return refuse(StatusCode::bad_argument);
    }
    watchdog_ms_ = set->timeout_ms;
  } else if (const auto* clear = std::get_if<ClearFaults>(&r)) {
    faults_ &= static_cast<std::uint16_t>(~clear->mask);
    if (!(faults_ & (fault::led_open | fault::led_short))) led_fault_channels_ = 0;
    if (temperature_c_ >= options_.temperature_limit_c) faults_ |= fault::over_temperature;
    response.result = FaultsReply{faults_};
  } else if (const auto* on = std::get_if<ChannelOn>(&r)) {
    if (!channel_ok(on->channel)) return refuse(StatusCode::bad_argument);
    if (faults_ & fault::blocking) return refuse(StatusCode::faulted);
    turn_on(on->channel, now);
  } else if (std::holds_alternative<AllOff>(r)) {
    all_off(now);
  } else if (const auto* level = std::get_if<SetIntensity>(&r)) {
    if (!channel_ok(level->channel) || level->permille > intensity_full_scale) {
      return refuse(StatusCode::bad_argument);
    }
    Output& output = outputs_[level->channel];
    output.permille = level->permille;
    if (output.on && on_switch_) {
      on_switch_(level->channel, true, output.permille / double{intensity_full_scale}, now);
    }
  } else if (const auto* flash = std::get_if<Strobe>(&r)) {
    if (!channel_ok(flash->channel) || flash->duration_us == 0 ||
        flash->duration_us > options_.strobe_max_us) {
      return refuse(StatusCode::bad_argument);
    }
    if (faults_ & fault::blocking) return refuse(StatusCode::faulted);
    turn_on(flash->channel, now);
    if (on_channel_ == flash->channel) {  // not switched off at once by an LED fault
      strobing_ = true;
      strobe_end_ = now + std::chrono::microseconds(flash->duration_us);
    }
  }
  return response;
}

void StrobeFirmware::advance(Clock::time_point now) {
  {
    const std::scoped_lock lock(mutex_);
    advance_locked(std::max(now, latest_));
  }
  wake_.notify_all();
}

void StrobeFirmware::advance_locked(Clock::time_point now) {
  latest_ = std::max(latest_, now);
  // In deadline order, each at its own time, as the timer hardware would.
  while (true) {
    const bool strobe_due = strobing_ && strobe_end_ <= now;
    const Clock::time_point trip = last_feed_ + std::chrono::milliseconds(watchdog_ms_);
    const bool watchdog_due = watchdog_armed_ && trip <= now;
    if (strobe_due && (!watchdog_due || strobe_end_ <= trip)) {
      all_off(strobe_end_);
    } else if (watchdog_due) {
      watchdog_armed_ = false;
      latch(fault::watchdog, trip);
    } else {
      break;
    }
  }
}

std::optional<Clock::time_point> StrobeFirmware::next_deadline_locked() const {
  std::optional<Clock::time_point> next;
  if (strobing_) next = strobe_end_;
  if (watchdog_armed_) {
    const Clock::time_point trip = last_feed_ + std::chrono::milliseconds(watchdog_ms_);
    next = next ? std::min(*next, trip) : trip;
  }
  return next;
}

void StrobeFirmware::drive(int channel, bool on, Clock::time_point at) {
  Output& output = outputs_[static_cast<std::size_t>(channel)];
  if (output.on == on) return;
  output.on = on;
  history_.push_back({at, channel, on});
  if (on_switch_) {
    on_switch_(channel, on, on ? output.permille / double{intensity_full_scale} : 0.0, at);
  }
}

void StrobeFirmware::turn_on(int channel, Clock::time_point at) {
  all_off(at);
  drive(channel, true, at);
  on_channel_ = channel;
  // The driver measures the LED as soon as current flows.
  const LedFault fault = outputs_[static_cast<std::size_t>(channel)].fault;
  if (fault != LedFault::none) {
    led_fault_channels_ |= static_cast<std::uint8_t>(1u << channel);
    latch(fault == LedFault::open ? fault::led_open : fault::led_short, at);
  }
}

void StrobeFirmware::all_off(Clock::time_point at) {
  for (std::size_t channel = 0; channel < outputs_.size(); ++channel) {
    drive(static_cast<int>(channel), false, at);
  }
  on_channel_ = -1;
  strobing_ = false;
}

void StrobeFirmware::latch(std::uint16_t faults, Clock::time_point at) {
  faults_ |= faults;
  if (faults & fault::blocking) all_off(at);
}

void StrobeFirmware::set_temperature(double celsius, Clock::time_point now) {
  {
    const std::scoped_lock lock(mutex_);
    now = std::max(now, latest_);
    advance_locked(now);
    temperature_c_ = celsius;
    if (celsius >= options_.temperature_limit_c) latch(fault::over_temperature, now);
  }
  wake_.notify_all();
}

void StrobeFirmware::set_led_fault(int channel, LedFault fault) {
  const std::scoped_lock lock(mutex_);
  if (channel < 0 || channel >= static_cast<int>(outputs_.size())) return;
  outputs_[static_cast<std::size_t>(channel)].fault = fault;
  if (fault != LedFault::none && on_channel_ == channel) {
    led_fault_channels_ |= static_cast<std::uint8_t>(1u << channel);
    latch(fault == LedFault::open ? fault::led_open : fault::led_short, latest_);
  }
}

void StrobeFirmware::usb_disconnect(Clock::time_point now) {
  {
    const std::scoped_lock lock(mutex_);
    now = std::max(now, latest_);
    advance_locked(now);
    all_off(now);
    watchdog_armed_ = false;
  }
  wake_.notify_all();
}

DeviceStatus StrobeFirmware::status_locked() const {
  DeviceStatus s;
  s.faults = faults_;
  s.on_channel = static_cast<std::uint8_t>(on_channel_ < 0 ? no_channel : on_channel_);
  s.strobing = strobing_;
  s.watchdog_armed = watchdog_armed_;
  s.led_fault_channels = led_fault_channels_;
  s.temperature_decidegrees = static_cast<std::int16_t>(temperature_c_ * 10);
  s.watchdog_ms = watchdog_ms_;
  return s;
}

DeviceStatus StrobeFirmware::status() const {
  const std::scoped_lock lock(mutex_);
  return status_locked();
}

std::vector<int> StrobeFirmware::channels_on() const {
  const std::scoped_lock lock(mutex_);
  std::vector<int> on;
  for (std::size_t channel = 0; channel < outputs_.size(); ++channel) {
    if (outputs_[channel].on) on.push_back(static_cast<int>(channel));
  }
  return on;
}

double StrobeFirmware::level(int channel) const {
  const std::scoped_lock lock(mutex_);
  if (channel < 0 || channel >= static_cast<int>(outputs_.size())) return 0;
  return outputs_[static_cast<std::size_t>(channel)].permille / double{intensity_full_scale};
}

std::vector<SwitchEvent> StrobeFirmware::history() const {
  const std::scoped_lock lock(mutex_);
  return history_;
}

int StrobeFirmware::handled(Opcode opcode) const {
  const std::scoped_lock lock(mutex_);
  const auto it = handled_.find(opcode);
  return it == handled_.end() ? 0 : it->second;
}

}  // namespace psrig::test
