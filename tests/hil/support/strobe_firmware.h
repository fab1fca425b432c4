#pragma once
// The USB strobe controller's firmware, simulated: the device side of
// lights/PROTOCOL.md with the same safety rules as the real one
// (never two channels on, a watchdog, hardware-timed strobes, latched
// faults). It sees frames, not USB: the hardware-in-the-loop tests put it
// behind an emulated usbdevfs device; unit tests call it directly.
//
// Time is the caller's: every call takes `now`, and advance() runs the
// timers (strobe ends, watchdog) up to a time, so tests can drive a clock
// by hand. start_timer() runs them on a thread against the real clock
// instead, as the MCU's timer interrupt would. Thread-safe.

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <span>
#include <thread>
#include <vector>

#include "psrig/lights/strobe_protocol.h"
#include "psrig/lights/switch_log.h"

namespace psrig::test {

// What the controller is: its channels, version and limits.
struct StrobeFirmwareOptions {
  int channels = 3;
  lights::strobe::Version firmware{1, 2, 0};
  std::uint16_t default_watchdog_ms = 1000;
  std::uint16_t watchdog_min_ms = 50;
  std::uint16_t watchdog_max_ms = 10000;
  std::uint32_t strobe_max_us = 1'000'000;
  double temperature_limit_c = 70;
};

class StrobeFirmware {
 public:
  using Options = StrobeFirmwareOptions;
  // A channel's output changed at `at` (level 0..1 when on): drives the
  // simulated rig's LEDs (sim::SimulatedLeds::set_led). Called with the firmware's lock
  // held: it must not call back into the firmware.
  using OnSwitch =
      std::function<void(int channel, bool on, double level, lights::Clock::time_point at)>;
  enum class LedFault { none, open, shorted };

  explicit StrobeFirmware(Options options = {}, OnSwitch on_switch = {});
  ~StrobeFirmware();
  StrobeFirmware(const StrobeFirmware&) = delete;
  StrobeFirmware& operator=(const StrobeFirmware&) = delete;

  // One bulk OUT transfer, received at `now`; returns the bulk IN response
  // (empty for a zero-length transfer, which gets none).
  [[nodiscard]] lights::strobe::Frame receive(std::span<const std::uint8_t> bytes,
                                              lights::Clock::time_point now = lights::Clock::now());
  // Runs the timers up to `now`: strobes end, the watchdog trips.
  void advance(lights::Clock::time_point now);
  // Runs the timers on a thread of their own, in real time, until
  // stop_timer() or destruction.
  void start_timer();
  void stop_timer();

  // What the world does to the controller.
  void set_temperature(double celsius, lights::Clock::time_point now = lights::Clock::now());
  // A broken LED, found (and latched) whenever its channel is driven on.
  void set_led_fault(int channel, LedFault fault);
  // USB reset, suspend or VBUS lost (unplugged): all off, watchdog idle.
  void usb_disconnect(lights::Clock::time_point now = lights::Clock::now());

  // What the firmware did and is doing.
  [[nodiscard]] lights::strobe::DeviceStatus status() const;
  [[nodiscard]] std::vector<int> channels_on() const;
  [[nodiscard]] double level(int channel) const;  // intensity set, 0..1
  // Every output change in time order (channel -1 never appears: each
  // channel switches on its own).
  [[nodiscard]] std::vector<lights::SwitchEvent> history() const;
  // How many commands with this opcode were answered ok.
  [[nodiscard]] int handled(lights::strobe::Opcode opcode) const;
  [[nodiscard]] const Options& options() const { return options_; }

 private:
  struct Output {
    bool on = false;
    std::uint16_t permille = lights::strobe::intensity_full_scale;
    LedFault fault = LedFault::none;
  };

  lights::strobe::Response execute(const lights::strobe::Command& command,
                                   lights::Clock::time_point now);
  void advance_locked(lights::Clock::time_point now);
  [[nodiscard]] std::optional<lights::Clock::time_point> next_deadline_locked() const;
  void drive(int channel, bool on, lights::Clock::time_point at);
  void turn_on(int channel, lights::Clock::time_point at);  // break before make
  void all_off(lights::Clock::time_point at);
  void latch(std::uint16_t faults, lights::Clock::time_point at);
  [[nodiscard]] lights::strobe::DeviceStatus status_locked() const;

  const Options options_;
  const OnSwitch on_switch_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;  // the timer thread: deadlines changed, or stop
  std::thread timer_;
  bool stop_ = false;

  std::vector<Output> outputs_;
  int on_channel_ = -1;
  bool strobing_ = false;
  lights::Clock::time_point strobe_end_{};
  bool watchdog_armed_ = false;
  lights::Clock::time_point last_feed_{};
  std::uint16_t watchdog_ms_;
  std::uint16_t faults_ = 0;
  std::uint8_t led_fault_channels_ = 0;
  double temperature_c_ = 25;
  lights::Clock::time_point latest_{};  // time never runs backwards, whoever calls
  std::vector<lights::SwitchEvent> history_;
  std::map<lights::strobe::Opcode, int> handled_;
};

}  // namespace psrig::test
