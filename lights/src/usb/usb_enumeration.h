#pragma once
// The USB devices of one VID:PID, each opened and its serial read: one walk
// of libusb's device list for the strobe controller backend (usb_lights) and
// for `psrig devices` (device_discovery). Private to lights.

#include <cstdint>
#include <expected>
#include <libusb.h>
#include <memory>
#include <string>
#include <vector>

namespace psrig::lights {

struct UsbContextCloser {
  void operator()(libusb_context* context) const { libusb_exit(context); }
};
struct UsbHandleCloser {
  void operator()(libusb_device_handle* handle) const { libusb_close(handle); }
};
using UsbContext = std::unique_ptr<libusb_context, UsbContextCloser>;
using UsbHandle = std::unique_ptr<libusb_device_handle, UsbHandleCloser>;

// What a libusb call returned on failure (LIBUSB_ERROR_*), for libusb_strerror.
using UsbErrorCode = int;

struct MatchingUsbDevice {
  std::uint8_t bus = 0;
  std::uint8_t address = 0;
  UsbHandle handle;             // null when libusb_open failed
  UsbErrorCode open_error = 0;  // why it failed, when handle is null
  std::string serial;           // empty when it has none or was not opened
};

[[nodiscard]] std::expected<UsbContext, UsbErrorCode> start_libusb();

// In libusb's order. The handles must be closed before the context exits.
[[nodiscard]] std::expected<std::vector<MatchingUsbDevice>, UsbErrorCode> open_usb_devices(
    libusb_context* context, std::uint16_t vendor_id, std::uint16_t product_id);

}  // namespace psrig::lights
