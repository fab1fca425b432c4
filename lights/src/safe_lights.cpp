#include "psrig/lights/safe_lights.h"

#include "psrig/base/log.h"
#include "psrig/lights/emergency_stop.h"

namespace psrig::lights {

SafeLights::SafeLights(std::unique_ptr<LightController> backend, std::chrono::milliseconds max_on)
    : backend_(std::move(backend)), max_on_(max_on) {
  register_lights(this);
  watchdog_ = std::thread([this] { watch(); });
}

SafeLights::~SafeLights() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    (void)off_locked();
  }
  changed_.notify_all();
  watchdog_.join();
  unregister_lights(this);
}

Status SafeLights::off_locked() {
  auto off = backend_->all_off();
  if (!off) off = backend_->all_off();  // once more: a transient fault must not leave an LED on
  lit_.reset();
  return off;
}

Status SafeLights::turn_on(int channel) {
  if (channel < 0 || channel >= backend_->channel_count())
    return std::unexpected(internal_error("lights: no channel " + std::to_string(channel) + " (" +
                                          std::to_string(backend_->channel_count()) +
                                          " channels)"));
  {
    std::lock_guard lock(mutex_);
    if (lit_) {
      if (auto off = off_locked(); !off) return std::unexpected(off.error());
    }
    if (auto on = backend_->turn_on(channel); !on) {
      const auto off = off_locked();
      Error error = on.error();
      error.message += off ? "; all LEDs switched off"
                           : "; switching all LEDs off failed too: " + off.error().message;
      return std::unexpected(error);
    }
    lit_ = channel;
    lit_since_ = Clock::now();
    timed_out_ = false;
  }
  changed_.notify_all();
  return {};
}

Status SafeLights::all_off() {
  std::lock_guard lock(mutex_);
  return off_locked();
}

Status SafeLights::set_intensity(int channel, double level) {
  std::lock_guard lock(mutex_);
  if (auto set = backend_->set_intensity(channel, level); !set) {
    (void)off_locked();
    return set;
  }
  return {};
}

std::optional<std::pair<int, Clock::time_point>> SafeLights::lit() const {
  std::lock_guard lock(mutex_);
  if (!lit_) return std::nullopt;
  return std::pair{*lit_, lit_since_};
}

void SafeLights::emergency_off() {
  std::lock_guard lock(mutex_);
  (void)off_locked();
}

void SafeLights::watch() {
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    if (!lit_) {
      changed_.wait(lock);
      continue;
    }
    const auto deadline = lit_since_ + max_on_;
    if (changed_.wait_until(lock, deadline) == std::cv_status::timeout && lit_ &&
        Clock::now() >= lit_since_ + max_on_) {
      logger("lights")->error("LED {} on for more than {} ms: switched off", *lit_,
                              max_on_.count());
      (void)off_locked();
      timed_out_ = true;
    }
  }
}

}  // namespace psrig::lights
