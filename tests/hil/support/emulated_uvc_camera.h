#pragma once
// An emulated USB Video Class camera as libcamera's uvcvideo pipeline
// handler finds it: the USB device and its video interface in sysfs under
// a PCI host controller that has a firmware (ACPI) node, a media
// controller device (/dev/mediaN, driver "uvcvideo") whose graph has the
// camera's default video entity tied to the video node, and the video node
// itself (/dev/videoN), an EmulatedV4l2Camera made pollable: a PTY that
// turns readable while a buffer is done, memfd-backed buffers exported as
// dmabufs, and imported dmabufs. libcamera's camera id is then
// "\_SB_.PCI0.XHC_-<port>:1.0-<vendor>:<product>", its model the card name.
//
// libcamera 0.0.3 opens video nodes with syscall(SYS_openat), past
// umockdev's preload library: the test process needs
// libpsrig_hil_openat_shim.so preloaded before it (openat_syscall_shim.cpp);
// available() says whether both are there, in that order.

#include <memory>
#include <string>

#include "emulated_media_device.h"
#include "emulated_v4l2_camera.h"
#include "umockdev_bed.h"

namespace psrig::test {

struct EmulatedUvcOptions {
  std::string card = "psrig UVC camera";
  std::string vendor_id = "1209";  // pid.codes' test ids
  std::string product_id = "0001";
  std::string port = "1";  // the USB device is 1-<port>
  // The video node's formats, sizes and timing (name, card, driver,
  // parent and pollable are set here).
  EmulatedV4l2Options video;
};

class EmulatedUvcCamera {
 public:
  EmulatedUvcCamera(UmockdevBed& bed, EmulatedUvcOptions options, FrameSource source);

  // Under umockdev with the openat shim loaded too.
  [[nodiscard]] static bool available();

  // The id libcamera gives the camera.
  [[nodiscard]] std::string camera_id() const;
  [[nodiscard]] EmulatedV4l2Camera& video() { return *video_; }
  [[nodiscard]] EmulatedMediaDevice& media() { return *media_; }

  // Unplugged: the video node, then the media device, leave with "remove"
  // uevents; both answer ENODEV from then on.
  void unplug();

 private:
  EmulatedUvcOptions options_;
  std::string interface_path_;  // the USB interface the nodes hang under, with /sys
  std::unique_ptr<EmulatedV4l2Camera> video_;
  std::unique_ptr<EmulatedMediaDevice> media_;
};

}  // namespace psrig::test
