#pragma once
// The simulated rig's LEDs: which channel is on, at what level, since when.
// The sim light backend switches them (and so do the emulated GPIO chip,
// USB controller and Modbus driver of the hardware-in-the-loop tests); the
// simulated world (sim/world.h) asks how much each shone over an exposure.
// No images here, so the production light backends carry no OpenCV.
// Thread-safe.

#include <memory>
#include <mutex>
#include <vector>

#include "psrig/config/rig_config.h"
#include "psrig/lights/switch_log.h"

namespace psrig::sim {

class SimulatedLeds {
 public:
  explicit SimulatedLeds(int channels);

  // The LEDs of the simulated rig `config` describes (simulated_rig.h):
  // the same instance for every holder of an equivalent configuration.
  [[nodiscard]] static std::shared_ptr<SimulatedLeds> attach(const config::RigConfig& config);

  [[nodiscard]] int channel_count() const { return channels_; }

  // LED `channel` on at `level` (0..1) or off, from now (or `at`).
  void set_led(int channel, bool on, double level = 1.0,
               lights::Clock::time_point at = lights::Clock::now());
  void all_off(lights::Clock::time_point at = lights::Clock::now());
  [[nodiscard]] std::vector<int> leds_on() const;
  // Everything switched, for the never-two-on check.
  [[nodiscard]] const lights::SwitchLog& log() const { return log_; }

  // How much of [begin, end) each LED shone, weighted by its level: 0 when
  // off throughout, 1 when on at full level throughout.
  [[nodiscard]] std::vector<double> exposure_weights(lights::Clock::time_point begin,
                                                     lights::Clock::time_point end) const;

 private:
  struct Switch {
    lights::Clock::time_point time;
    int channel;  // -1: all
    bool on;
    double level;
  };

  int channels_;
  mutable std::mutex mutex_;
  std::vector<Switch> history_;  // in time order
  lights::SwitchLog log_;
};

}  // namespace psrig::sim
