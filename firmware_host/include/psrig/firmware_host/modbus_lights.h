#pragma once
// The modbus light backend: a Modbus LED driver over RTU or TCP through libmodbus (lights.modbus).

#include <memory>

#include "psrig/config/rig_config.h"
#include "psrig/firmware_host/light_controller.h"

namespace psrig::firmware_host {

// Connects to the driver, checks it answers, all off.
[[nodiscard]] Result<std::unique_ptr<LightController>> open_modbus_lights(
    const config::LightsConfig& config);

}  // namespace psrig::firmware_host
