#pragma once
// An emulated USB device as Linux's usbdevfs presents it to libusb: the
// sysfs entry libusb enumerates (descriptors, bus and device numbers) and
// the /dev/bus/usb/BBB/DDD node whose ioctls (URBs submitted, reaped and
// discarded, interfaces claimed, halts cleared) are answered here, from
// C++, on the UmockdevBed's thread. String descriptor requests are
// answered from the description; data sent to an OUT endpoint goes to a
// handler; IN endpoints return what queue_in() put there. Faults: a
// stalled endpoint, an unplugged device.

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "umockdev_bed.h"

namespace psrig::test {

class UsbfsDevice {
 public:
  struct Endpoint {
    std::uint8_t address = 0x81;  // bit 7: IN
    std::uint8_t attributes = 2;  // 2 bulk, 3 interrupt
    std::uint16_t max_packet = 64;
  };
  struct Description {
    std::uint16_t vendor_id = 0;
    std::uint16_t product_id = 0;
    std::uint16_t bcd_device = 0x0100;
    std::string manufacturer;
    std::string product;
    std::string serial;
    std::uint8_t interface_class = 0xFF;
    std::vector<Endpoint> endpoints;
    int busnum = 1;
    int devnum = 1;
  };
  // Data the host sent to an OUT endpoint. Called on the bed's thread,
  // with no lock held: it may call queue_in().
  using OnOut = std::function<void(std::uint8_t endpoint, std::vector<std::uint8_t> data)>;

  UsbfsDevice(UmockdevBed& bed, Description description, OnOut on_out);
  ~UsbfsDevice();  // destroy the host side (libusb) first
  UsbfsDevice(const UsbfsDevice&) = delete;
  UsbfsDevice& operator=(const UsbfsDevice&) = delete;

  // Attaches the emulation and adds the device to sysfs and /dev.
  void plug();
  // As a yanked cable: URBs in flight complete with -ESHUTDOWN, every
  // later ioctl fails with ENODEV, and the device leaves sysfs.
  void unplug();
  // One IN transfer's worth of data for `endpoint`.
  void queue_in(std::uint8_t endpoint, std::vector<std::uint8_t> data);
  // The next `times` URBs on `endpoint` stall (-EPIPE): each halts it until
  // the host clears the halt; an IN URB waiting now is the first.
  void stall(std::uint8_t endpoint, int times = 1);
  [[nodiscard]] int halts_cleared(std::uint8_t endpoint) const;
  [[nodiscard]] int interfaces_claimed() const;

  [[nodiscard]] std::string devnode() const;
  [[nodiscard]] std::string syspath() const;
  // The raw sysfs `descriptors`: device descriptor, then configuration 1.
  [[nodiscard]] std::vector<std::uint8_t> descriptors() const;

 private:
  struct Urb {
    UMockdevIoctlData* urb = nullptr;     // the usbdevfs_urb, resolved (a reference we hold)
    UMockdevIoctlData* buffer = nullptr;  // its buffer, resolved (idem), or null
  };

  bool on_ioctl(UMockdevIoctlClient* client);
  bool submit(UMockdevIoctlClient* client, std::vector<std::uint8_t>& out_data,
              std::uint8_t& out_endpoint);
  void control(Urb& urb);
  void complete(Urb urb, int status, int actual_length);  // ready to reap
  void fill_in(Urb& urb, std::deque<std::vector<std::uint8_t>>& queue);
  void hand_to_reaper();  // a blocking REAPURB waiting, and an URB ready
  static void reap_into(UMockdevIoctlClient* client, Urb urb);
  static void release(Urb& urb);
  [[nodiscard]] std::vector<std::uint8_t> string_descriptor(int index, int length) const;

  UmockdevBed& bed_;
  const Description description_;
  const OnOut on_out_;
  mutable std::mutex mutex_;
  bool plugged_ = false;
  bool unplugged_ = false;
  std::vector<Urb> waiting_;                // IN URBs without data yet
  std::deque<Urb> ready_;                   // completed, to be reaped
  std::deque<UMockdevIoctlClient*> reapers_;  // blocking REAPURBs, unanswered
  std::map<std::uint8_t, std::deque<std::vector<std::uint8_t>>> in_queues_;
  std::map<std::uint8_t, int> stalls_left_;
  std::map<std::uint8_t, bool> halted_;
  std::map<std::uint8_t, int> halts_cleared_;
  int interfaces_claimed_ = 0;
};

}  // namespace psrig::test
