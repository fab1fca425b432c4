#pragma once
// The usb light backend: the rig's USB strobe controller through libusb (lights.usb; protocol in
// lights/PROTOCOL.md).

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "psrig/config/rig_config.h"
#include "psrig/lights/light_controller.h"
#include "psrig/lights/strobe_protocol.h"

struct libusb_context;
struct libusb_device_handle;

namespace psrig::lights {

// The controller as a LightController, plus what only it can do. Any
// transport failure (timeout, a stall that clearing the halt did not cure,
// the device gone) breaks the link for good: the heartbeat stops, so the
// controller's watchdog turns everything off even if the host's last
// ALL_OFF did not get through, and every later call returns that error.
// Open it again to go on.
class UsbStrobeLights final : public LightController {
 public:
  // All off (best effort), heartbeat stopped, interface released.
  ~UsbStrobeLights() override;
  UsbStrobeLights(const UsbStrobeLights&) = delete;
  UsbStrobeLights& operator=(const UsbStrobeLights&) = delete;

  [[nodiscard]] int channel_count() const override { return channels_; }
  [[nodiscard]] Status turn_on(int channel) override;
  [[nodiscard]] Status all_off() override;
  [[nodiscard]] Status set_intensity(int channel, double level) override;
  [[nodiscard]] std::string describe() const override;

  // Turns `channel` on for `duration`, timed by the controller, which turns
  // it off by itself; returns at once. The log records the off at the first
  // call (or heartbeat) after the strobe has ended.
  [[nodiscard]] Status strobe(int channel, std::chrono::microseconds duration);
  // The controller's status: latched faults, the channel on, temperature.
  [[nodiscard]] Result<strobe::DeviceStatus> read_status();
  // Clears every latched fault; returns those whose cause persists.
  [[nodiscard]] Result<std::uint16_t> clear_faults();
  // Stops (true) or resumes feeding the controller's watchdog: a self-test
  // that the controller turns everything off when the host falls silent.
  void hold_heartbeat(bool held);

  [[nodiscard]] const strobe::DeviceInfo& info() const { return info_; }
  [[nodiscard]] const std::string& serial() const { return serial_; }

 private:
  friend Result<std::unique_ptr<UsbStrobeLights>> open_usb_strobe(
      const config::LightsConfig& config);
  UsbStrobeLights(const config::LightsConfig& config, libusb_context* context,
                  libusb_device_handle* handle, std::string node, std::string serial);

  [[nodiscard]] Status handshake();
  // One command and its response, under the lock on the link; a transport
  // failure breaks the link.
  [[nodiscard]] Result<strobe::Response> exchange(std::unique_lock<std::mutex>& link,
                                                  const strobe::Request& request);
  // The same, and a refusal (status other than ok) is an error saying why.
  [[nodiscard]] Result<strobe::Response> command(std::unique_lock<std::mutex>& link,
                                                 const strobe::Request& request,
                                                 const std::string& what);
  // Checks `level` (0 to 1) and sends it as `channel`'s intensity.
  [[nodiscard]] Status send_intensity(std::unique_lock<std::mutex>& link, int channel, double level);
  [[nodiscard]] std::string transport_message(strobe::Opcode opcode, int code,
                                              std::uint8_t endpoint, bool stalled_twice) const;
  // Marks the link broken (no more heartbeats), tries one ALL_OFF unless
  // the device is gone, and returns the error every later call gets.
  [[nodiscard]] Error break_link(std::unique_lock<std::mutex>& link, const std::string& message,
                                 bool device_gone);
  [[nodiscard]] Error refused(std::unique_lock<std::mutex>& link, strobe::Opcode opcode,
                              const std::string& what, strobe::StatusCode status);
  void notice_offs(const strobe::Response& response);  // what the controller switched off itself
  void record_on(int channel);
  void record_all_off();
  void heartbeat_loop();
  [[nodiscard]] std::string name() const;

  const config::UsbLights usb_;
  const int channels_;
  const std::vector<double> intensity_;
  libusb_context* context_;
  libusb_device_handle* handle_;
  const std::string node_;
  const std::string serial_;
  strobe::DeviceInfo info_;

  std::mutex link_;  // one exchange at a time; guards what follows
  std::uint8_t seq_ = 0;
  std::optional<Error> broken_;
  int logged_on_ = -1;  // the channel log_ has on
  int strobe_channel_ = -1;
  Clock::time_point strobe_end_{};

  std::mutex beat_mutex_;  // guards the heartbeat's flags
  std::condition_variable beat_wake_;
  bool stopping_ = false;
  bool held_ = false;
  std::thread heartbeat_;
};

// Finds the controller by VID:PID (and serial), claims it, checks its
// protocol version, clears latched faults, sets the watchdog and the
// intensities, all off, and starts feeding the watchdog.
[[nodiscard]] Result<std::unique_ptr<UsbStrobeLights>> open_usb_strobe(
    const config::LightsConfig& config);

// The same, as the `usb` backend of open_lights().
[[nodiscard]] Result<std::unique_ptr<LightController>> open_usb_lights(
    const config::LightsConfig& config);

}  // namespace psrig::lights
