#pragma once
// An emulated USB device as Linux's usbfs presents it to libusb: the sysfs
// entry libusb enumerates (descriptors, bus and device numbers) and the
// /dev/bus/usb/BBB/DDD node whose ioctls (URBs submitted, reaped and
// discarded, interfaces claimed, halts cleared) are answered here, on the
// UmockdevBed's thread. Standard control requests (descriptors, strings)
// are answered from the description; data sent to a bulk OUT endpoint goes
// to a handler; bulk IN URBs return what queue_in() put there, and wait
// until something is. Faults: a stalled endpoint, an unplugged device.
//
// What the kernel does and this does not: there is no POLLERR on unplug
// (umockdev's device node is a plain file, always ready), so libusb learns
// of the unplug from the URBs (-ESHUTDOWN) and ioctls (ENODEV) instead, as
// it does when an unplug races a transfer on real hardware.

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <set>
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
    std::string serial;  // empty: no iSerialNumber
    std::uint8_t interface_class = 0xFF;
    std::vector<Endpoint> endpoints;  // of interface 0, configuration 1
    int busnum = 1;
    int devnum = 2;
    int port = 1;  // on the root hub: sysfs name "<busnum>-<port>"
  };
  // Data the host sent to a bulk OUT endpoint, after its URB completed.
  // Called on the bed's thread with no lock held: it may call queue_in(),
  // stall() and unplug().
  using OnOut = std::function<void(std::uint8_t endpoint, std::vector<std::uint8_t> data)>;

  UsbfsDevice(UmockdevBed& bed, Description description, OnOut on_out);
  ~UsbfsDevice();  // close the host side (libusb) first
  UsbfsDevice(const UsbfsDevice&) = delete;
  UsbfsDevice& operator=(const UsbfsDevice&) = delete;

  // Attaches the emulation and adds the device to sysfs and /dev.
  void plug();
  // As a yanked cable: URBs in flight complete with -ESHUTDOWN, every
  // later ioctl fails with ENODEV (a reap, once the completed URBs are
  // gone), and the device leaves sysfs with a "remove" uevent.
  void unplug();
  // One IN transfer's worth of data for `endpoint`.
  void queue_in(std::uint8_t endpoint, std::vector<std::uint8_t> data);
  // The next `times` URBs on `endpoint` stall (-EPIPE), each halting it
  // until the host clears the halt; an IN URB waiting now is the first.
  // Data queued for an IN endpoint stays queued.
  void stall(std::uint8_t endpoint, int times = 1);

  [[nodiscard]] int halts_cleared(std::uint8_t endpoint) const;
  [[nodiscard]] int interfaces_claimed() const;  // by any open file, now
  [[nodiscard]] bool plugged() const;
  [[nodiscard]] std::string devnode() const;  // /dev/bus/usb/BBB/DDD
  [[nodiscard]] std::string sysname() const;  // e.g. 1-1
  // The raw sysfs `descriptors`: device descriptor, then configuration 1.
  [[nodiscard]] std::vector<std::uint8_t> descriptors() const;

 private:
  struct Urb {
    UMockdevIoctlClient* client = nullptr;  // the open file that submitted it (a reference)
    unsigned long address = 0;              // of the usbdevfs_urb in the client
    std::uint8_t endpoint = 0;
    UMockdevIoctlData* urb = nullptr;     // the usbdevfs_urb, resolved (a reference)
    UMockdevIoctlData* buffer = nullptr;  // its buffer, resolved (a reference), or null
  };

  bool on_ioctl(UMockdevIoctlClient* client);
  bool submit(UMockdevIoctlClient* client, std::vector<std::uint8_t>& out_data,
              std::uint8_t& out_endpoint);
  bool reap(UMockdevIoctlClient* client);
  bool discard(UMockdevIoctlClient* client);
  bool claim(UMockdevIoctlClient* client, bool release);
  void control(Urb& urb);
  void complete_locked(Urb urb, int status, int actual_length);  // ready to reap
  void fill_locked(Urb& urb, std::vector<std::uint8_t> data);
  bool halts_locked(Urb& urb);  // a stall or a halt ends it with -EPIPE
  static void release(Urb& urb);
  [[nodiscard]] std::vector<std::uint8_t> string_descriptor(int index) const;
  [[nodiscard]] std::string syspath() const;
  [[nodiscard]] std::string description_text() const;  // umockdev's format

  UmockdevBed& bed_;
  const Description description_;
  const OnOut on_out_;
  mutable std::mutex mutex_;
  bool plugged_ = false;
  bool unplugged_ = false;
  std::vector<Urb> waiting_;  // IN URBs without data yet
  std::deque<Urb> ready_;     // completed, to be reaped
  std::map<std::uint8_t, std::deque<std::vector<std::uint8_t>>> in_queues_;
  std::map<std::uint8_t, int> stalls_left_;
  std::set<std::uint8_t> halted_;
  std::map<std::uint8_t, int> halts_cleared_;
  std::map<unsigned, UMockdevIoctlClient*> claims_;  // interface → the file holding it
};

}  // namespace psrig::test
