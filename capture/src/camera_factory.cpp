#include "psrig/capture/camera.h"
#include "psrig/capture/sim_camera.h"

namespace psrig::capture {

Result<std::unique_ptr<Camera>> open_camera(const config::RigConfig& config,
                                            std::shared_ptr<firmware_host::SimWorld> world) {
  std::unique_ptr<Camera> camera;
  if (config.camera.backend == "sim") {
    if (!world) return std::unexpected(processing::internal_error("camera.backend \"sim\" needs the simulated world"));
    camera = open_sim_camera(config, std::move(world));
  } else {
    return std::unexpected(processing::bad_input(config.source, "camera.backend",
                                                 "\"" + config.camera.backend + "\" is not built into this psrig"));
  }
  if (auto ok = camera->configure(config.camera); !ok) return std::unexpected(ok.error());
  return camera;
}

}  // namespace psrig::capture
