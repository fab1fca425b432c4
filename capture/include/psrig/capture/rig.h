#pragma once
// The rig a configuration describes, opened: its lights behind the safety
// layer, its camera configured, and the simulated world when either is
// simulated.

#include <functional>
#include <memory>

#include "psrig/capture/camera.h"
#include "psrig/capture/scan_sequencer.h"
#include "psrig/config/rig_config.h"
#include "psrig/firmware_host/safe_lights.h"
#include "psrig/firmware_host/sim/sim_world.h"

namespace psrig::capture {

struct Rig {
  std::shared_ptr<firmware_host::SimWorld> world;  // null on an all-hardware rig
  std::unique_ptr<firmware_host::SafeLights> lights;
  std::unique_ptr<Camera> camera;  // null when not asked for

  // A scan request that carries the simulated world's answer when the
  // camera is simulated.
  [[nodiscard]] ScanRequest request(const config::RigConfig& config) const;
};

// What open_rig() puts round each device it opens, before the lights go
// behind the safety layer (the daemon records which device fails). Unset:
// the device as opened.
struct RigWrappers {
  std::function<std::unique_ptr<firmware_host::LightController>(
      std::unique_ptr<firmware_host::LightController>)>
      lights;
  std::function<std::unique_ptr<Camera>(std::unique_ptr<Camera>)> camera;
};

// An error opening a device says which: ErrorCode::lights or ErrorCode::camera.
[[nodiscard]] Result<Rig> open_rig(const config::RigConfig& config, bool with_camera = true,
                                   const RigWrappers& wrappers = {});

}  // namespace psrig::capture
