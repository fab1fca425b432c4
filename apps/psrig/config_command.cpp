// psrig config check FILE: is this rig.toml right? Errors and warnings with
// file, line, column and key; a summary of what it describes.

#include <cstdio>
#include <memory>
#include <string>

#include "command.h"
#include "psrig/calibration/calibration_status.h"
#include "psrig/calibration/calibration_store.h"

namespace psrig::cli {

Command add_config_command(CLI::App& parent) {
  auto file = std::make_shared<std::string>();
  CLI::App* app = parent.add_subcommand("config", "Work with rig configurations");
  CLI::App* check = app->add_subcommand("check", "Check a rig.toml and say what it describes");
  check->add_option("file", *file, "The configuration file")->required();
  app->require_subcommand(1);

  return {
      app, [file] {
        int exit_code = 0;
        auto config = load_config_or_report("config check", *file, exit_code);
        if (!config) return exit_code;
        std::printf("%s: ok\n", file->c_str());
        std::printf("lights: %s, %d channels, slant %.1f deg\n", config->lights.backend.c_str(),
                    config->lights.channels, config->geometry.slant_deg);
        std::printf("camera: %s %s, exposure %d us, gain %.2f, %d frames averaged\n",
                    config->camera.backend.c_str(),
                    config->camera.backend == "sim" ? "" : config->camera.device.c_str(),
                    config->camera.exposure_us, config->camera.gain, config->camera.frames_average);
        std::printf("scans go to: %s\n", config->storage.root.string().c_str());
        const calibration::CalibrationStore store(config->storage.root);
        if (const auto current = store.current()) {
          auto stored = calibration::read_calibration(*current);
          if (!stored)
            std::printf("light calibration: %s does not read (%s)\n", current->c_str(),
                        stored.error().message.c_str());
          else
            std::printf("light calibration: %s (%s, %zu lights)%s\n", current->c_str(),
                        stored->document.value("created", std::string("undated")).c_str(),
                        stored->lights.size(),
                        stored->lights.size() == static_cast<std::size_t>(config->lights.channels)
                            ? ""
                            : ": not for this rig's lights, so scans use the geometry");
        } else {
          std::printf(
              "light calibration: none in %s; scans use the geometry above (psrig "
              "calibrate lights measures it)\n",
              store.directory().c_str());
        }
        const auto age = calibration::calibration_status(store, config->calibration.max_age_days);
        if (!age.missing) {
          const std::string sections = nlohmann::json(age.sections).dump();
          std::printf("calibration %s: %s, %s%s\n", age.version.c_str(), sections.c_str(),
                      age.age_days
                          ? (std::to_string(static_cast<int>(*age.age_days)) + " days old").c_str()
                          : "undated",
                      age.stale ? " (stale: older than [calibration] max_age_days; calibrate again)"
                      : config->calibration.max_age_days == 0 ? " (max_age_days = 0: never stale)"
                                                              : "");
        }
        const auto& d = config->daemon;
        std::string modbus = "off";
        if (d.modbus_port != 0) {
          modbus = d.modbus_address + ":" + std::to_string(d.modbus_port) + " (from ";
          if (d.modbus_allow.empty()) modbus += "anyone";
          for (std::size_t i = 0; i < d.modbus_allow.size(); ++i)
            modbus += (i == 0 ? "" : ", ") + d.modbus_allow[i];
          modbus += ")";
        }
        std::printf("psrigd: http://%s:%d (%s), %d scans may wait, Modbus %s\n",
                    d.listen_address.c_str(), d.port, d.token.empty() ? "no token" : "bearer token",
                    d.queue_limit, modbus.c_str());
        return 0;
      }};
}

}  // namespace psrig::cli
