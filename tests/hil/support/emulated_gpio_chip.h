#pragma once
// A GPIO chip emulated in user space: /dev/gpiochipN and its sysfs entries
// in a umockdev testbed, answering the GPIO character device's v1 uAPI (the
// one libgpiod 1.6 speaks) the way the kernel does: chip and line info, line
// handles, setting and reading values. Lines keep their physical level;
// active-low requests invert what the handle sees, as in the kernel. Tests
// listen to the levels (to light a simulated LED, say) and read the chip's
// own record of them. Faults: lines held by another consumer, value sets
// that fail, the chip vanishing.

#include <cstdint>
#include <functional>
#include <linux/gpio.h>
#include <mutex>
#include <set>
#include <string>
#include <sys/stat.h>
#include <sys/types.h>
#include <vector>

#include "umockdev_bed.h"

namespace psrig::test {

class EmulatedGpioChip {
 public:
  struct Options {
    std::string name = "gpiochip0";  // also the /dev node
    std::string label = "psrig-sim";
    unsigned lines = 32;
    unsigned minor = 0;     // device number 254:minor; one per chip in a bed
    int initial_level = 0;  // every line's physical level before anyone drives it
  };

  // Physical levels of every line before and after a change; called on the
  // testbed's handler thread, under the chip's lock (do not call back).
  using Listener =
      std::function<void(const std::vector<int>& before, const std::vector<int>& after)>;

  // Adds the chip to `bed`, which must outlive it.
  EmulatedGpioChip(UmockdevBed& bed, Options options);
  ~EmulatedGpioChip();
  EmulatedGpioChip(const EmulatedGpioChip&) = delete;
  EmulatedGpioChip& operator=(const EmulatedGpioChip&) = delete;

  void set_listener(Listener listener);
  // Line `offset` is held by someone else (a kernel driver, another
  // program): line info names `consumer`, requests get EBUSY.
  void hold(unsigned offset, const std::string& consumer);
  // The next `count` value sets fail with `error` (and change nothing).
  void fail_sets(int count, int error);
  // The chip vanishes after `sets` more successful value sets (0: now): its
  // sysfs and /dev entries go, every ioctl on a descriptor still open gets
  // ENODEV, and its lines keep the levels they had (no one drives them now).
  void vanish_after(int sets);
  void vanish() { vanish_after(0); }

  [[nodiscard]] const std::string& devnode() const { return devnode_; }
  [[nodiscard]] bool vanished() const;
  // Physical levels now, and after every change since the chip appeared
  // (its own record, one entry per request or value set).
  [[nodiscard]] std::vector<int> levels() const;
  [[nodiscard]] std::vector<std::vector<int>> history() const;
  // Lines requested through a handle that is still open, and by whom.
  [[nodiscard]] std::set<unsigned> requested() const;
  [[nodiscard]] std::string consumer(unsigned offset) const;
  // GPIOHANDLE_REQUEST_* flags of the line's open handle (0: none).
  [[nodiscard]] std::uint32_t request_flags(unsigned offset) const;
  // Every ioctl request code the chip and its handles were sent.
  [[nodiscard]] std::set<unsigned long> requests_seen() const;

 private:
  struct Line {
    int level = 0;        // physical
    std::string held_by;  // someone else's, set by hold()
    int handle = -1;      // index into handles_, -1: free
  };
  struct Handle {
    std::vector<unsigned> offsets;
    std::uint32_t flags = 0;
    std::string consumer;
    std::string devnode;  // the node its fd is open on
    int fd = -1;
    dev_t node_dev = 0;  // the node file's identity, to tell whether fd is still it
    ino_t node_ino = 0;
    bool open = false;
  };

  bool on_chip_ioctl(UMockdevIoctlClient* client);
  bool on_handle_ioctl(int handle, UMockdevIoctlClient* client);
  bool get_chip_info(UMockdevIoctlClient* client);
  bool get_line_info(UMockdevIoctlClient* client);
  bool get_line_handle(UMockdevIoctlClient* client);
  bool set_values(Handle& handle, UMockdevIoctlClient* client);
  bool get_values(Handle& handle, UMockdevIoctlClient* client);
  void release_closed_handles();  // what the kernel does when a handle's fd is closed
  std::vector<int> levels_locked() const;
  void change(const std::vector<int>& after);
  void vanish_locked();

  UmockdevBed& bed_;
  Options options_;
  std::string devnode_, syspath_;
  mutable std::mutex mutex_;
  std::vector<Line> lines_;
  std::vector<Handle> handles_;
  std::vector<std::vector<int>> history_;
  std::set<unsigned long> requests_seen_;
  Listener listener_;
  int fail_count_ = 0, fail_error_ = 0;
  int vanish_after_ = -1;  // value sets left before vanishing; -1: never
  bool vanished_ = false;
};

}  // namespace psrig::test
