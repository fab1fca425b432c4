#pragma once
// The sim camera backend: the simulated world's sensor with real frame timing (camera.backend =
// "sim"). It finds its world through the configuration (sim::World::attach), so it sees what
// the simulated rig's LEDs do.

#include <memory>

#include "psrig/cameras/camera.h"

namespace psrig::sim {

// Bad input when the world cannot be made (sim.pattern names no usable pattern).
[[nodiscard]] Result<std::unique_ptr<cameras::Camera>> open_sim_camera(
    const config::RigConfig& config);

}  // namespace psrig::sim
