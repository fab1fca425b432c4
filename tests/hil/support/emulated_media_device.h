#pragma once
// An emulated media controller device (/dev/mediaN) for hardware-in-the-loop
// tests: what libcamera reads to find a camera's parts before it opens any
// of them. It answers MEDIA_IOC_DEVICE_INFO and MEDIA_IOC_G_TOPOLOGY (the
// entities, their pads, the data links between pads, and the interface
// links that tie an entity to its device node by major and minor) as the
// kernel's media core does, and MEDIA_IOC_ENUM_ENTITIES for older callers.
// The graph is fixed at construction; links cannot be set up.
//
// On umockdev 0.17 (Debian 12) the node is a regular file (it needs no
// poll or mmap), served by UmockdevBed; unplug() makes every later request
// fail with ENODEV, as the media core answers once the device is
// unregistered, after the testbed has sent the "remove" uevent that tells
// udev listeners (libcamera's hot-unplug) it is gone, and the device has
// left sysfs and /dev.

#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

#include "umockdev_bed.h"

namespace psrig::test {

struct MediaGraph {
  struct Entity {
    std::uint32_t id = 0;
    std::string name;
    std::uint32_t function = 0;  // MEDIA_ENT_F_*
    std::uint32_t flags = 0;     // MEDIA_ENT_FL_*
  };
  struct Interface {
    std::uint32_t id = 0;
    std::uint32_t type = 0;  // MEDIA_INTF_T_*
    std::uint32_t major = 0, minor = 0;
  };
  struct Pad {
    std::uint32_t id = 0;
    std::uint32_t entity_id = 0;
    std::uint32_t flags = 0;  // MEDIA_PAD_FL_SINK or _SOURCE
    std::uint32_t index = 0;  // among its entity's pads
  };
  struct Link {
    std::uint32_t id = 0;
    std::uint32_t source_id = 0;  // a pad, or for an interface link the interface
    std::uint32_t sink_id = 0;    // a pad, or for an interface link the entity
    std::uint32_t flags = 0;      // MEDIA_LNK_FL_*, with the link type
  };
  std::vector<Entity> entities;
  std::vector<Interface> interfaces;
  std::vector<Pad> pads;
  std::vector<Link> links;
};

struct EmulatedMediaOptions {
  std::string name = "media0";  // the node is /dev/<name>
  std::string parent;           // the sysfs device it hangs under ("/sys/devices/...")
  std::uint32_t major = 239, minor = 0;
  std::string driver;  // "uvcvideo" for a UVC camera
  std::string model;
  std::string serial;
  std::string bus_info;
  MediaGraph graph;
};

class EmulatedMediaDevice {
 public:
  EmulatedMediaDevice(UmockdevBed& bed, EmulatedMediaOptions options);
  ~EmulatedMediaDevice();
  EmulatedMediaDevice(const EmulatedMediaDevice&) = delete;
  EmulatedMediaDevice& operator=(const EmulatedMediaDevice&) = delete;

  [[nodiscard]] std::string devnode() const { return "/dev/" + options_.name; }
  [[nodiscard]] std::string syspath() const { return syspath_; }
  [[nodiscard]] std::uint32_t major() const { return options_.major; }
  [[nodiscard]] std::uint32_t minor() const { return options_.minor; }

  // The device is unregistered: a "remove" uevent, out of sysfs and /dev,
  // ENODEV from then on.
  void unplug();
  // How many requests it has answered (G_TOPOLOGY and the rest).
  [[nodiscard]] int requests() const;

 private:
  bool handle(UMockdevIoctlClient* client);
  int topology(UMockdevIoctlClient* client);

  UmockdevBed& bed_;
  EmulatedMediaOptions options_;
  std::string syspath_;
  mutable std::mutex mutex_;
  bool unplugged_ = false;
  int requests_ = 0;
};

}  // namespace psrig::test
