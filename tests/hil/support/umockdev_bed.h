#pragma once
// A umockdev testbed whose emulated devices answer from C++: sysfs and
// /dev entries that the real libgpiod, V4L2 and libusb code paths open,
// with ioctl, read and write requests served by handlers running on a
// thread of their own (the code under test blocks until they answer).
// Only works under umockdev's preload library (umockdev-wrapper);
// available() says whether it is there, and tests skip when it is not.

#include <cstring>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <umockdev.h>
#include <vector>

namespace psrig::test {

class UmockdevBed {
 public:
  // An ioctl, read or write from the code under test; answer it with
  // complete() (result and errno), after reading and writing its argument.
  using Handler = std::function<bool(UMockdevIoctlClient* client)>;

  UmockdevBed();
  ~UmockdevBed();
  UmockdevBed(const UmockdevBed&) = delete;
  UmockdevBed& operator=(const UmockdevBed&) = delete;

  [[nodiscard]] static bool available();

  // A device with sysfs attributes and udev properties (name/value pairs);
  // returns its sysfs path.
  std::string add_device(const std::string& subsystem, const std::string& name,
                         const std::string& parent,
                         const std::vector<std::pair<std::string, std::string>>& attributes,
                         const std::vector<std::pair<std::string, std::string>>& properties);
  // Devices in umockdev's text format (P:, N:, E:, A:, H: lines). Unlike
  // add_device this creates the /dev node file (an `N:` line), which device
  // emulation needs; attach the handler first.
  void add_from_string(const std::string& description);
  void remove_device(const std::string& syspath);
  // A /sys/bus/<bus>/devices/<name> link to a device at `syspath`
  // ("/sys/devices/..."), unless umockdev made it already: libgpiod, for
  // one, checks a chip there.
  void add_bus_link(const std::string& bus, const std::string& syspath);
  // udevd's database entry for the character device major:minor, which
  // tells libudev the device is initialised (listed by enumerations that
  // match initialised devices only). libudev reads it from /run/udev/data,
  // which umockdev does not redirect: only code that runs with the openat
  // shim preloaded too (openat_syscall_shim.cpp) finds it in the testbed.
  void add_udev_entry(unsigned major, unsigned minor);

  // Serves requests on `devnode` (e.g. "/dev/gpiochip0") with the handlers
  // given (any may be empty: then the request fails with ENOTTY / EIO).
  // Attach before the device is added. May be called from a handler (the
  // emulated GPIO chip attaches a node per line handle it hands out).
  void attach(const std::string& devnode, Handler on_ioctl, Handler on_read = {},
              Handler on_write = {});
  void detach(const std::string& devnode);

  // Runs `f` on the thread that serves the handlers, and waits for it: a
  // device that changes (unplugs, completes a waiting URB) there cannot
  // race its own handlers, and touches a request's memory only where
  // umockdev syncs it to the client.
  void on_bed_thread(const std::function<void()>& f);

  [[nodiscard]] UMockdevTestbed* testbed() const { return bed_; }
  [[nodiscard]] std::string root() const;

 private:
  struct Attached {
    UMockdevIoctlBase* base = nullptr;
    Handler on_ioctl, on_read, on_write;
  };
  static gboolean dispatch_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* client,
                                 gpointer attached);
  static gboolean dispatch_read(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer attached);
  static gboolean dispatch_write(UMockdevIoctlBase*, UMockdevIoctlClient* client,
                                 gpointer attached);

  UMockdevTestbed* bed_ = nullptr;
  GMainContext* context_ = nullptr;
  GMainLoop* loop_ = nullptr;
  std::thread thread_;
  std::mutex mutex_;  // attached_: handlers attach too
  std::map<std::string, Attached*> attached_;
};

// What a request's argument points at, `offset` bytes in, as a T: read
// from the client, and written back to it when the request is answered
// (answer() before this goes out of scope).
template <class T>
class Pointee {
 public:
  explicit Pointee(UMockdevIoctlClient* client, std::size_t offset = 0)
      : data_(umockdev_ioctl_data_resolve(umockdev_ioctl_client_get_arg(client), offset, sizeof(T),
                                          nullptr)) {}
  // `T` at the address stored `offset` bytes into `parent` (a pointer field).
  Pointee(UMockdevIoctlData* parent, std::size_t offset, std::size_t length = sizeof(T))
      : data_(umockdev_ioctl_data_resolve(parent, offset, length, nullptr)) {}
  ~Pointee() {
    if (data_) umockdev_ioctl_data_unref(data_);
  }
  Pointee(const Pointee&) = delete;
  Pointee& operator=(const Pointee&) = delete;

  [[nodiscard]] explicit operator bool() const { return data_ != nullptr; }
  T& operator*() { return *reinterpret_cast<T*>(data_->data); }  // g_malloc'd: aligned for any T
  T* operator->() { return reinterpret_cast<T*>(data_->data); }
  [[nodiscard]] UMockdevIoctlData* data() const { return data_; }

 private:
  UMockdevIoctlData* data_;
};

// Completes the request with `result` (and errno `error` when it failed).
inline bool answer(UMockdevIoctlClient* client, long result, int error = 0) {
  umockdev_ioctl_client_complete(client, result, error);
  return true;
}

}  // namespace psrig::test
