#include "usb_enumeration.h"

#include <array>
#include <sys/types.h>
#include <utility>

namespace psrig::lights {
namespace {

struct DeviceListFreer {
  void operator()(libusb_device** list) const { libusb_free_device_list(list, 1); }
};

std::string read_serial(libusb_device_handle* handle, std::uint8_t index) {
  if (index == 0) return {};
  std::array<unsigned char, 128> text{};
  const int length =
      libusb_get_string_descriptor_ascii(handle, index, text.data(), text.size() - 1);
  return length > 0 ? std::string(reinterpret_cast<const char*>(text.data()),
                                  static_cast<std::size_t>(length))
                    : std::string();
}

}  // namespace

std::expected<UsbContext, UsbErrorCode> start_libusb() {
  libusb_context* context = nullptr;
  if (const int code = libusb_init(&context); code < 0) return std::unexpected(code);
  return UsbContext(context);
}

std::expected<std::vector<MatchingUsbDevice>, UsbErrorCode> open_usb_devices(
    libusb_context* context, std::uint16_t vendor_id, std::uint16_t product_id) {
  libusb_device** raw_list = nullptr;
  const ssize_t count = libusb_get_device_list(context, &raw_list);
  if (count < 0) return std::unexpected(static_cast<UsbErrorCode>(count));
  // An open handle holds its device, so the list may go before the handles.
  const std::unique_ptr<libusb_device*, DeviceListFreer> list(raw_list);

  std::vector<MatchingUsbDevice> found;
  for (ssize_t i = 0; i < count; ++i) {
    libusb_device* device = list.get()[i];
    libusb_device_descriptor descriptor{};
    if (libusb_get_device_descriptor(device, &descriptor) != 0 ||
        descriptor.idVendor != vendor_id || descriptor.idProduct != product_id) {
      continue;
    }
    MatchingUsbDevice match;
    match.bus = libusb_get_bus_number(device);
    match.address = libusb_get_device_address(device);
    libusb_device_handle* handle = nullptr;
    if (const int code = libusb_open(device, &handle); code < 0) {
      match.open_error = code;
    } else {
      match.handle.reset(handle);
      match.serial = read_serial(handle, descriptor.iSerialNumber);
    }
    found.push_back(std::move(match));
  }
  return found;
}

}  // namespace psrig::lights
