#pragma once
// The rig's devices as rig.toml names them: the light backend
// (`lights.backend`: gpiod, usb, modbus, sim) and the camera
// (`camera.backend`: v4l2, libcamera, sim). Here, above every backend family,
// so that no family knows the others.

#include <memory>

#include "psrig/base/error.h"
#include "psrig/cameras/camera.h"
#include "psrig/config/rig_config.h"
#include "psrig/lights/light_controller.h"

namespace psrig::rig {

// The backend `lights.backend` names, opened and ready; errors name the
// device, the configuration key and the fix.
[[nodiscard]] Result<std::unique_ptr<lights::LightController>> open_lights(
    const config::RigConfig& config);

// The backend `camera.backend` names, opened and configured; errors name
// the device, the configuration key and the fix.
[[nodiscard]] Result<std::unique_ptr<cameras::Camera>> open_camera(const config::RigConfig& config);

}  // namespace psrig::rig
