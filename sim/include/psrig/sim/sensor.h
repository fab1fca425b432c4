#pragma once
// The simulated camera's sensor: what it records of the simulated world
// over one exposure. Exposure and gain scale the light, the colour matrix
// (when configured) mixes the channels, vignetting darkens
// the corners, shot noise (from the full-well capacity) and read noise are
// added, then the black level, and the result is quantised to the ADC's bit
// depth in a 16-bit container. Deterministic for a seed and frame number.

#include <cstdint>
#include <optional>

#include <opencv2/core.hpp>

#include "psrig/config/rig_config.h"
#include "psrig/sim/world.h"

namespace psrig::sim {

struct SensorSettings {
  int exposure_us = 20000;
  double gain = 1.0;
  int channels = 3;  // 3: BGR, 1: grey (the mean of the channels)
};

class Sensor {
 public:
  Sensor(const config::SimConfig& config, std::uint64_t seed);

  // The frame of an exposure over [begin, begin + exposure), CV_16UC3 or C1.
  [[nodiscard]] cv::Mat expose(const World& world, Clock::time_point begin,
                               const SensorSettings& settings, std::uint64_t frame_number) const;

  [[nodiscard]] double white_level() const { return (1 << bit_depth_) - 1; }
  [[nodiscard]] double black_level() const { return black_level_; }

 private:
  int bit_depth_;
  double full_well_;
  double read_noise_;
  double black_level_;  // in output codes
  double vignetting_;
  double led_irradiance_;
  double ambient_;
  std::optional<cv::Matx33f> colour_bgr_;  // scene BGR to camera BGR; absent: identity
  std::uint64_t seed_;
};

}  // namespace psrig::sim
