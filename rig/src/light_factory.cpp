#include "psrig/lights/gpiod_lights.h"
#include "psrig/lights/light_controller.h"
#include "psrig/lights/modbus_lights.h"
#include "psrig/lights/usb_lights.h"
#include "psrig/rig/open_devices.h"
#include "psrig/sim/sim_lights.h"

namespace psrig::rig {

using lights::LightController;
namespace {

// Settings errors point into the file they came from.
Result<std::unique_ptr<LightController>> from_file(Result<std::unique_ptr<LightController>> opened,
                                                   const std::filesystem::path& source) {
  if (!opened && opened.error().kind == ErrorKind::bad_input && opened.error().file.empty())
    opened.error().file = source;
  return opened;
}

}  // namespace

Result<std::unique_ptr<LightController>> open_lights(const config::RigConfig& config) {
  const auto& lights = config.lights;
  if (lights.backend == "sim") return sim::open_sim_lights(config);
  if (lights.backend == "gpiod") return from_file(lights::open_gpiod_lights(lights), config.source);
  if (lights.backend == "usb") return from_file(lights::open_usb_lights(lights), config.source);
  if (lights.backend == "modbus")
    return from_file(lights::open_modbus_lights(lights), config.source);
  return std::unexpected(
      bad_input(config.source, "lights.backend",
                "\"" + lights.backend + "\" is not one of gpiod, usb, modbus, sim"));
}

}  // namespace psrig::rig
