#include "psrig/firmware_host/gpiod_lights.h"
#include "psrig/firmware_host/light_controller.h"
#include "psrig/firmware_host/sim_lights.h"

namespace psrig::firmware_host {

Result<std::unique_ptr<LightController>> open_lights(const config::RigConfig& config,
                                                     std::shared_ptr<SimWorld> world) {
  const auto& lights = config.lights;
  if (lights.backend == "sim") {
    if (!world)
      return std::unexpected(
          processing::internal_error("lights.backend \"sim\" needs the simulated world"));
    return open_sim_lights(lights, std::move(world));
  }
  if (lights.backend == "gpiod") {
    auto opened = open_gpiod_lights(lights);
    // A wrong value in the configuration is reported against its file.
    if (!opened && opened.error().kind == processing::ErrorKind::bad_input &&
        opened.error().file.empty()) {
      Error error = opened.error();
      error.file = config.source;
      return std::unexpected(error);
    }
    return opened;
  }
  return std::unexpected(processing::bad_input(
      config.source, "lights.backend", "\"" + lights.backend + "\" is not built into this psrig"));
}

}  // namespace psrig::firmware_host
