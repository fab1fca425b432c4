#pragma once
// The simulated rig's world: a procedural swatch under the rig's LEDs and a
// little room light. The simulated lights (and the emulated GPIO chip, USB
// controller and Modbus driver of the hardware-in-the-loop tests) switch
// its LEDs; the simulated sensor asks it what the swatch looked like over
// an exposure. Thread-safe.

#include <mutex>
#include <vector>

#include <opencv2/core.hpp>

#include "psrig/config/rig_config.h"
#include "psrig/firmware_host/sim/swatch_model.h"
#include "psrig/firmware_host/switch_log.h"

namespace psrig::firmware_host {

class SimWorld {
 public:
  explicit SimWorld(const config::RigConfig& config);

  [[nodiscard]] int channel_count() const { return static_cast<int>(directions_.size()); }
  // Unit directions toward each LED, camera axes, from the configuration's geometry.
  [[nodiscard]] const std::vector<cv::Vec3d>& light_directions() const { return directions_; }
  [[nodiscard]] const sim::Swatch& swatch() const { return swatch_; }

  // LED `channel` on at `level` (0..1) or off, from now (or `at`).
  void set_led(int channel, bool on, double level = 1.0, Clock::time_point at = Clock::now());
  void all_off(Clock::time_point at = Clock::now());
  [[nodiscard]] std::vector<int> leds_on() const;
  // Everything switched, for the never-two-on check.
  [[nodiscard]] const SwitchLog& log() const { return log_; }

  // How much of [begin, end) each LED shone, weighted by its level: 0 when
  // off throughout, 1 when on at full level throughout.
  [[nodiscard]] std::vector<double> exposure_weights(Clock::time_point begin,
                                                     Clock::time_point end) const;

  // Linear radiance of the swatch (CV_32FC3, BGR) under LED `channel` at
  // full level, relative to the LED's irradiance at normal incidence.
  [[nodiscard]] const cv::Mat& radiance(int channel) const { return radiance_[channel]; }
  // Under the room light alone (diffuse, from all directions), same scale.
  [[nodiscard]] const cv::Mat& ambient() const { return ambient_; }

 private:
  struct Switch {
    Clock::time_point time;
    int channel;  // -1: all
    bool on;
    double level;
  };

  std::vector<cv::Vec3d> directions_;
  sim::Swatch swatch_;
  std::vector<cv::Mat> radiance_;
  cv::Mat ambient_;
  mutable std::mutex mutex_;
  std::vector<Switch> history_;  // in time order
  SwitchLog log_;
};

}  // namespace psrig::firmware_host
