// psrig devices: what hardware this board can see, in the words rig.toml
// takes (camera.device, lights.gpiod.chip, lights.modbus.device, ...), so an
// engineer wiring a rig knows what to write.

#include <cstdio>
#include <memory>

#include "command.h"
#include "psrig/cameras/camera_discovery.h"
#include "psrig/lights/device_discovery.h"

namespace psrig::cli {
namespace {

void print_section(const char* title, const std::vector<lights::FoundDevice>& devices) {
  std::printf("%s:\n", title);
  if (devices.empty()) std::printf("  none found\n");
  for (const auto& d : devices)
    std::printf("  %s  %s\n", d.path.c_str(), d.description.c_str());
}

}  // namespace

Command add_devices_command(CLI::App& parent) {
  auto config_file = std::make_shared<std::string>();
  CLI::App* app =
      parent.add_subcommand("devices",
                            "List the cameras, GPIO chips, USB strobe controllers and serial "
                            "ports this board can see");
  app->add_option("--config", *config_file,
                  "Take the USB controller's vendor and product ids from this rig.toml");

  return {
      app, [config_file] {
        config::RigConfig config;
        if (!config_file->empty()) {
          int exit_code = 0;
          auto loaded = load_config_or_report("devices", *config_file, exit_code);
          if (!loaded) return exit_code;
          config = std::move(*loaded);
        }
        std::printf("cameras:\n");
        const auto cameras = cameras::find_cameras();
        if (cameras.empty()) std::printf("  none found\n");
        for (const auto& c : cameras)
          std::printf("  %-9s %s  %s\n", c.backend.c_str(), c.device.c_str(),
                      c.description.c_str());
        print_section("GPIO chips (lights.gpiod.chip)", lights::find_gpio_chips());
        char usb_title[96];
        std::snprintf(usb_title, sizeof usb_title, "USB strobe controllers %04x:%04x (lights.usb)",
                      config.lights.usb.vendor_id, config.lights.usb.product_id);
        print_section(usb_title, lights::find_usb_strobe_controllers(config.lights.usb.vendor_id,
                                                                     config.lights.usb.product_id));
        print_section("serial ports (lights.modbus.device)", lights::find_serial_ports());
        return 0;
      }};
}

}  // namespace psrig::cli
