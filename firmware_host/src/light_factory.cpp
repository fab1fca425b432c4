#include "psrig/firmware_host/light_controller.h"
#include "psrig/firmware_host/modbus_lights.h"
#include "psrig/firmware_host/sim_lights.h"

namespace psrig::firmware_host {

Result<std::unique_ptr<LightController>> open_lights(const config::RigConfig& config, std::shared_ptr<SimWorld> world) {
  const auto& lights = config.lights;
  if (lights.backend == "sim") {
    if (!world) return std::unexpected(processing::internal_error("lights.backend \"sim\" needs the simulated world"));
    return open_sim_lights(lights, std::move(world));
  }
  if (lights.backend == "modbus") {
    auto opened = open_modbus_lights(lights);
    // Settings errors point into the file they came from.
    if (!opened && opened.error().kind == processing::ErrorKind::bad_input &&
        opened.error().file.empty())
      opened.error().file = config.source;
    return opened;
  }
  return std::unexpected(
      processing::bad_input(config.source, "lights.backend", "\"" + lights.backend + "\" is not built into this psrig"));
}

}  // namespace psrig::firmware_host
