#pragma once
// The rig a configuration describes, opened: its lights behind the safety
// layer, its camera configured, and the simulated world when the camera is
// simulated. The one place that opens a rig, for the command line and psrigd.

#include <functional>
#include <memory>

#include "psrig/cameras/camera.h"
#include "psrig/config/rig_config.h"
#include "psrig/lights/safe_lights.h"
#include "psrig/rig/scan_sequencer.h"

// The world's header brings the cloth's (and Eigen's) along; a rig's
// holders need only hold it (include psrig/sim/world.h to look inside).
namespace psrig::sim {
class World;
}

namespace psrig::rig {

struct Rig {
  // The simulated camera's world (sim::World::attach): its LEDs' log for
  // tests; null when the camera is real or not asked for.
  std::shared_ptr<sim::World> world;
  std::unique_ptr<lights::SafeLights> lights;
  std::unique_ptr<cameras::Camera> camera;  // null when not asked for

  // A scan request with the rig's current light calibration applied.
  [[nodiscard]] ScanRequest request(const config::RigConfig& config) const;
};

// What open_rig() puts round each device it opens, before the lights go
// behind the safety layer (the daemon records which device fails). Unset:
// the device as opened.
struct RigWrappers {
  std::function<std::unique_ptr<lights::LightController>(std::unique_ptr<lights::LightController>)>
      lights;
  std::function<std::unique_ptr<cameras::Camera>(std::unique_ptr<cameras::Camera>)> camera;
};

// An error opening a device says which: ErrorCode::lights or ErrorCode::camera.
[[nodiscard]] Result<Rig> open_rig(const config::RigConfig& config, bool with_camera = true,
                                   const RigWrappers& wrappers = {});

}  // namespace psrig::rig
