#pragma once
// The gpiod light backend: LEDs on GPIO lines through libgpiod 1.6 (lights.gpiod).

#include <memory>

#include "psrig/config/rig_config.h"
#include "psrig/firmware_host/light_controller.h"

namespace psrig::firmware_host {

// Opens the chip and requests one output line per channel, all off.
[[nodiscard]] Result<std::unique_ptr<LightController>> open_gpiod_lights(
    const config::LightsConfig& config);

}  // namespace psrig::firmware_host
