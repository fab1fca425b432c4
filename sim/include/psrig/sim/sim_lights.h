#pragma once
// The sim light backend (lights.backend = "sim"): switches the simulated
// rig's LEDs (simulated_leds.h), found through the configuration, and
// appends each switch to lights.sim.switch_log when set
// (switch_log_file.h); an error only when that file cannot be opened.

#include <memory>

#include "psrig/config/rig_config.h"
#include "psrig/lights/light_controller.h"

namespace psrig::sim {

[[nodiscard]] Result<std::unique_ptr<lights::LightController>> open_sim_lights(
    const config::RigConfig& config);

}  // namespace psrig::sim
