#include "psrig/lights/device_discovery.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <libusb.h>
#include <linux/serial.h>
#include <memory>
#include <sys/ioctl.h>
#include <unistd.h>

#include "psrig/lights/gpiod_lights.h"
#include "usb/usb_enumeration.h"

namespace psrig::lights {
namespace {

namespace fs = std::filesystem;

std::string read_line(const fs::path& file) {
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);
  return line;
}

// The driver behind a tty's device: newer kernels put a serial-base "port"
// device between the tty and its UART or USB adapter.
std::string driver_name(const fs::path& device) {
  std::error_code ec;
  fs::path at = fs::canonical(device, ec);
  for (int up = 0; up < 4 && !ec && at.has_relative_path(); ++up, at = at.parent_path()) {
    const std::string name = fs::read_symlink(at / "driver", ec).filename().string();
    ec.clear();
    if (!name.empty() && name != "port" && name != "ctrl") return name;
  }
  return {};
}

// Device names sort as people read them: ttyS2 before ttyS10.
bool natural_less(const FoundDevice& a, const FoundDevice& b) {
  const auto split = [](const std::string& s) {
    const auto digits = s.find_last_not_of("0123456789") + 1;
    return std::pair{s.substr(0, digits), digits < s.size() ? std::stol(s.substr(digits)) : -1L};
  };
  return split(a.path) < split(b.path);
}

}  // namespace

std::vector<FoundDevice> find_gpio_chips() {
  std::vector<FoundDevice> found;
  for (const GpioChipEntry& chip : list_gpio_chips())
    found.push_back({"/dev/" + chip.name,
                     chip.open_error ? std::string("cannot open: ") + std::strerror(chip.open_error)
                                     : "label \"" + chip.label + "\", " +
                                           std::to_string(chip.lines) + " lines"});
  return found;
}

std::vector<FoundDevice> find_usb_strobe_controllers(std::uint16_t vendor_id,
                                                     std::uint16_t product_id) {
  std::vector<FoundDevice> found;
  const auto context = start_libusb();
  if (!context) return found;
  const auto devices = open_usb_devices(context->get(), vendor_id, product_id);
  if (!devices) return found;
  for (const MatchingUsbDevice& device : *devices) {
    char where[16];
    std::snprintf(where, sizeof where, "%03u:%03u", device.bus, device.address);
    std::string description = "strobe controller";
    if (!device.handle) {
      description += std::string(", cannot open: ") + libusb_strerror(device.open_error) +
                     " (the psrig user needs access to /dev/bus/usb)";
    } else if (!device.serial.empty()) {
      description += ", serial " + device.serial;
    }
    found.push_back({where, description});
  }
  return found;
}

std::vector<FoundDevice> find_serial_ports() {
  std::vector<FoundDevice> found;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator("/sys/class/tty", ec)) {
    const fs::path device = entry.path() / "device";
    if (!fs::exists(device, ec)) continue;  // virtual terminals and the like
    const std::string name = entry.path().filename().string();
    const std::string driver = driver_name(device);
    // 8250 UARTs register ports that are not there; ask the port.
    if (name.starts_with("ttyS")) {
      const int fd = ::open(("/dev/" + name).c_str(), O_RDWR | O_NONBLOCK | O_NOCTTY);
      if (fd < 0) continue;
      serial_struct info{};
      const bool present = ioctl(fd, TIOCGSERIAL, &info) == 0 && info.type != PORT_UNKNOWN;
      ::close(fd);
      if (!present) continue;
    }
    std::string description = driver.empty() ? "serial port" : driver;
    if (const std::string product = read_line(device / ".." / "product"); !product.empty())
      description += ", \"" + product + "\"";
    found.push_back({"/dev/" + name, description});
  }
  std::sort(found.begin(), found.end(), natural_less);
  return found;
}

}  // namespace psrig::lights
