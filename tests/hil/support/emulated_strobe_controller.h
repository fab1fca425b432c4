#pragma once
// The rig's USB strobe controller as the hardware-in-the-loop tests plug
// it in: the simulated firmware (strobe_firmware.h) behind an emulated
// usbfs device with the descriptors of lights/PROTOCOL.md, so that
// the real libusb backend talks to it through the kernel's interface.

#include <functional>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "psrig/lights/strobe_protocol.h"
#include "strobe_firmware.h"
#include "usbfs_device.h"

namespace psrig::test {

class EmulatedStrobeController {
 public:
  struct Options {
    std::string serial = "A17";
    int devnum = 2;  // on bus 1
    int port = 1;
    StrobeFirmwareOptions firmware;
  };
  // The wire, for tests that meddle with it: sees each command and the
  // firmware's answer (on the bed's thread) and returns what to send back,
  // or nothing for an answer lost.
  using Wire = std::function<std::optional<lights::strobe::Frame>(
      std::span<const std::uint8_t> command, lights::strobe::Frame answer)>;

  EmulatedStrobeController(UmockdevBed& bed, const Options& options)
      : firmware_(options.firmware),
        device_(bed, describe(options),
                [this](std::uint8_t, std::vector<std::uint8_t> data) { deliver(data); }) {
    device_.plug();
  }
  explicit EmulatedStrobeController(UmockdevBed& bed) : EmulatedStrobeController(bed, Options{}) {}

  void set_wire(Wire wire) {
    const std::scoped_lock lock(wire_mutex_);
    wire_ = std::move(wire);
  }
  // The cable pulled: the controller loses VBUS (all off) and leaves USB.
  void unplug() {
    firmware_.usb_disconnect();
    device_.unplug();
  }

  [[nodiscard]] StrobeFirmware& firmware() { return firmware_; }
  [[nodiscard]] UsbfsDevice& device() { return device_; }

 private:
  static UsbfsDevice::Description describe(const Options& options) {
    using namespace lights::strobe;
    const auto& version = options.firmware.firmware;
    return {.vendor_id = 0x1209,
            .product_id = 0x5053,
            .bcd_device = static_cast<std::uint16_t>((version.major << 8) | (version.minor << 4) |
                                                     version.patch),
            .manufacturer = "psrig",
            .product = "psrig strobe controller",
            .serial = options.serial,
            .interface_class = 0xFF,
            .endpoints = {{endpoint_out, 2, 64}, {endpoint_in, 2, 64}},
            .busnum = 1,
            .devnum = options.devnum,
            .port = options.port};
  }

  void deliver(const std::vector<std::uint8_t>& command) {
    auto answer = firmware_.receive(command);
    if (answer.empty()) return;  // a zero-length packet gets none
    std::optional<lights::strobe::Frame> sent = std::move(answer);
    {
      const std::scoped_lock lock(wire_mutex_);
      if (wire_) sent = wire_(command, std::move(*sent));
    }
    if (sent) device_.queue_in(lights::strobe::endpoint_in, std::move(*sent));
  }

  StrobeFirmware firmware_;
  std::mutex wire_mutex_;
  Wire wire_;
  UsbfsDevice device_;  // last: it calls into the others until it is gone
};

}  // namespace psrig::test
