#pragma once
// The simulated rig's world: a procedural swatch under the rig's LEDs and a
// little room light. The LEDs are the rig's SimulatedLeds (sim/simulated_leds.h),
// switched by the sim light backend or by a test's emulated driver; the
// simulated sensor asks the world what the swatch looked like over an
// exposure. Thread-safe.

#include <chrono>
#include <memory>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/config/rig_config.h"
#include "psrig/sim/simulated_leds.h"
#include "psrig/sim/swatch_model.h"

namespace psrig::sim {

using Clock = lights::Clock;

class World {
 public:
  // The world of `config` lit by `leds` (null: LEDs of its own, switched
  // through leds(); attach() gives the rig's world instead). Bad input,
  // naming sim.pattern, when the swatch's pattern cannot be read or made.
  [[nodiscard]] static Result<World> make(const config::RigConfig& config,
                                          std::shared_ptr<SimulatedLeds> leds = nullptr);

  // The world of the simulated rig `config` describes, lit by its LEDs
  // (SimulatedLeds::attach): the same instance for every holder of an
  // equivalent configuration (sim/simulated_rig.h).
  [[nodiscard]] static Result<std::shared_ptr<World>> attach(const config::RigConfig& config);

  [[nodiscard]] int channel_count() const { return static_cast<int>(directions_.size()); }
  // Unit directions toward each LED, camera axes, from the configuration's geometry.
  [[nodiscard]] const std::vector<cv::Vec3d>& light_directions() const { return directions_; }
  // Each LED's position in mm (near-field LEDs: config::led_positions_mm),
  // or empty when the LEDs are distant; the swatch is then lit by a point
  // source (render_point_light), the directions above are from the origin.
  [[nodiscard]] const std::vector<cv::Vec3d>& light_positions_mm() const { return positions_; }
  [[nodiscard]] const Swatch& swatch() const { return swatch_; }
  // What the swatch is made of ([sim] pattern); none for calibration targets.
  [[nodiscard]] const std::optional<SwatchPattern>& pattern() const { return pattern_; }
  [[nodiscard]] const std::shared_ptr<SimulatedLeds>& leds() const { return leds_; }

  // How much of [begin, end) each LED shone (SimulatedLeds::exposure_weights).
  [[nodiscard]] std::vector<double> exposure_weights(Clock::time_point begin,
                                                     Clock::time_point end) const {
    return leds_->exposure_weights(begin, end);
  }

  // Linear radiance of the swatch (CV_32FC3, BGR) under LED `channel` at
  // full level, relative to the LED's irradiance at normal incidence.
  [[nodiscard]] const cv::Mat& radiance(int channel) const { return radiance_[channel]; }
  // Under the room light alone (diffuse, from all directions), same scale.
  [[nodiscard]] const cv::Mat& ambient() const { return ambient_; }

 private:
  World(const config::RigConfig& config, Swatch scene, std::optional<SwatchPattern> pattern,
        std::shared_ptr<SimulatedLeds> leds);

  std::vector<cv::Vec3d> directions_;
  std::vector<cv::Vec3d> positions_;
  Swatch swatch_;
  std::optional<SwatchPattern> pattern_;
  std::vector<cv::Mat> radiance_;
  cv::Mat ambient_;
  std::shared_ptr<SimulatedLeds> leds_;
};

}  // namespace psrig::sim
