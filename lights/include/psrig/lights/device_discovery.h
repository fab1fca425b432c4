#pragma once
// What lighting hardware is connected, for `psrig devices`: GPIO chips, the
// rig's USB strobe controllers, serial ports (for a Modbus RTU driver).
// Finding nothing is an empty list, not an error.

#include <cstdint>
#include <string>
#include <vector>

namespace psrig::lights {

struct FoundDevice {
  std::string path;         // what goes into rig.toml: /dev/gpiochip0, 001:004, /dev/ttyUSB0
  std::string description;  // label, lines, serial number, driver...
};

[[nodiscard]] std::vector<FoundDevice> find_gpio_chips();
[[nodiscard]] std::vector<FoundDevice> find_usb_strobe_controllers(std::uint16_t vendor_id,
                                                                   std::uint16_t product_id);
[[nodiscard]] std::vector<FoundDevice> find_serial_ports();

}  // namespace psrig::lights
