#pragma once
// The sim camera backend: the simulated world's sensor with real frame timing (camera.backend =
// "sim").

#include <memory>

#include "psrig/capture/camera.h"

namespace psrig::capture {

[[nodiscard]] std::unique_ptr<Camera> open_sim_camera(
    const config::RigConfig& config, std::shared_ptr<firmware_host::SimWorld> world);

}  // namespace psrig::capture
