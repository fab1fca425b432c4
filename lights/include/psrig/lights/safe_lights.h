#pragma once
// The rig's safety layer, over any light backend:
// - at most one LED on at any time: turn_on switches the lit one off first;
// - every exit path turns all off: an error from the backend (then all off
//   is tried at once), destruction (exceptions unwind through it), a
//   timeout (a watchdog thread switches off an LED left on longer than
//   lights.max_on_ms), and SIGINT/SIGTERM or std::terminate (see
//   emergency_stop.h, which reaches every SafeLights alive).
// Thread-safe.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "psrig/lights/light_controller.h"

namespace psrig::lights {

class SafeLights {
 public:
  SafeLights(std::unique_ptr<LightController> backend, std::chrono::milliseconds max_on);
  ~SafeLights();
  SafeLights(const SafeLights&) = delete;
  SafeLights& operator=(const SafeLights&) = delete;

  [[nodiscard]] Status turn_on(int channel);
  [[nodiscard]] Status all_off();
  [[nodiscard]] Status set_intensity(int channel, double level);

  [[nodiscard]] int channel_count() const { return backend_->channel_count(); }
  [[nodiscard]] std::string describe() const { return backend_->describe(); }
  [[nodiscard]] const SwitchLog& log() const { return backend_->log(); }
  // The lit channel and since when, if one is.
  [[nodiscard]] std::optional<std::pair<int, Clock::time_point>> lit() const;
  // The watchdog switched an LED off that was on too long.
  [[nodiscard]] bool timed_out() const { return timed_out_; }

  // Everything off, now, whatever else is going on (emergency_stop.h).
  void emergency_off();

 private:
  void watch();
  Status off_locked();

  std::unique_ptr<LightController> backend_;
  const std::chrono::milliseconds max_on_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::optional<int> lit_;
  Clock::time_point lit_since_;
  bool stopping_ = false;
  std::atomic<bool> timed_out_{false};
  std::thread watchdog_;
};

}  // namespace psrig::lights
