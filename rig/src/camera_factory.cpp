#include "psrig/cameras/libcamera_camera.h"
#include "psrig/cameras/v4l2_camera.h"
#include "psrig/rig/open_devices.h"
#include "psrig/sim/sim_camera.h"

namespace psrig::rig {

Result<std::unique_ptr<cameras::Camera>> open_camera(const config::RigConfig& config) {
  std::unique_ptr<cameras::Camera> camera;
  if (config.camera.backend == "sim") {
    auto sim = sim::open_sim_camera(config);
    if (!sim) return std::unexpected(sim.error());
    camera = std::move(*sim);
  } else if (config.camera.backend == "v4l2") {
    auto v4l2 = cameras::open_v4l2_camera(config.camera);
    if (!v4l2) return std::unexpected(v4l2.error());
    camera = std::move(*v4l2);
  } else if (config.camera.backend == "libcamera") {
    auto libcamera = cameras::open_libcamera_camera(config.camera);
    if (!libcamera) return std::unexpected(libcamera.error());
    camera = std::move(*libcamera);
  } else {
    return std::unexpected(
        bad_input(config.source, "camera.backend",
                  "\"" + config.camera.backend + "\" is not built into this psrig"));
  }
  if (auto ok = camera->configure(config.camera); !ok) return std::unexpected(ok.error());
  return camera;
}

}  // namespace psrig::rig
