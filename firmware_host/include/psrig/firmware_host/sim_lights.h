#pragma once
// The sim light backend: the simulated world's LEDs (lights.backend = "sim").

#include <memory>

#include "psrig/config/rig_config.h"
#include "psrig/firmware_host/light_controller.h"

namespace psrig::firmware_host {

class SimWorld;
[[nodiscard]] std::unique_ptr<LightController> open_sim_lights(const config::LightsConfig& config,
                                                               std::shared_ptr<SimWorld> world);

}  // namespace psrig::firmware_host
