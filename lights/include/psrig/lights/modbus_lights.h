#pragma once
// The modbus light backend: a Modbus LED driver over RTU or TCP through libmodbus (lights.modbus).

#include <memory>

#include "psrig/config/rig_config.h"
#include "psrig/lights/light_controller.h"

namespace psrig::lights {

// Connects to the driver, checks its device id (writing nothing to another
// device), turns all off and confirms it, sets the configured intensities
// and refuses a driver reporting a fault. Register map: lights/README.md.
[[nodiscard]] Result<std::unique_ptr<LightController>> open_modbus_lights(
    const config::LightsConfig& config);

}  // namespace psrig::lights
