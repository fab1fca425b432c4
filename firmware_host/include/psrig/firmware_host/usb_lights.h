#pragma once
// The usb light backend: the rig's USB strobe controller through libusb (lights.usb; protocol in
// firmware_host/PROTOCOL.md).

#include <memory>

#include "psrig/config/rig_config.h"
#include "psrig/firmware_host/light_controller.h"

namespace psrig::firmware_host {

// Finds and opens the controller, checks its protocol version, all off, and
// keeps its watchdog fed while open.
[[nodiscard]] Result<std::unique_ptr<LightController>> open_usb_lights(
    const config::LightsConfig& config);

}  // namespace psrig::firmware_host
