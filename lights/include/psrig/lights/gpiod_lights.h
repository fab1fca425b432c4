#pragma once
// The gpiod light backend: LEDs on GPIO lines through libgpiod 1.6 (lights.gpiod).

#include <memory>
#include <string>
#include <vector>

#include "psrig/config/rig_config.h"
#include "psrig/lights/light_controller.h"

namespace psrig::lights {

// A GPIO chip in /dev, as far as it could be looked at.
struct GpioChipEntry {
  std::string name;  // gpiochip0
  std::string label;
  unsigned lines = 0;
  int open_error = 0;  // errno when it could not be opened
};

// Every /dev/gpiochipN, in numeric order.
[[nodiscard]] std::vector<GpioChipEntry> list_gpio_chips();

// Opens the chip and requests one output line per channel, all off.
[[nodiscard]] Result<std::unique_ptr<LightController>> open_gpiod_lights(
    const config::LightsConfig& config);

}  // namespace psrig::lights
