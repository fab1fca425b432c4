#pragma once
// The rig a configuration describes, opened: its lights behind the safety
// layer, its camera configured, and the simulated world when either is
// simulated.

#include <memory>

#include "psrig/capture/camera.h"
#include "psrig/capture/scan_sequencer.h"
#include "psrig/config/rig_config.h"
#include "psrig/firmware_host/safe_lights.h"
#include "psrig/sim/world.h"

namespace psrig::capture {

struct Rig {
  // The simulated camera's world (sim::World::attach), for the ground truth;
  // null when the camera is real or not asked for.
  std::shared_ptr<sim::World> world;
  std::unique_ptr<firmware_host::SafeLights> lights;
  std::unique_ptr<Camera> camera;  // null when not asked for

  // A scan request that carries the simulated world's answer when the
  // camera is simulated.
  [[nodiscard]] ScanRequest request(const config::RigConfig& config) const;
};

[[nodiscard]] Result<Rig> open_rig(const config::RigConfig& config, bool with_camera = true);

}  // namespace psrig::capture
