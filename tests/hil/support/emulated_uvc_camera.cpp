#include "emulated_uvc_camera.h"

#include <cstdlib>
#include <dlfcn.h>
#include <filesystem>
#include <fstream>
#include <linux/media.h>

namespace psrig::test {
namespace {

constexpr const char* kController = "/devices/pci0000:00/0000:00:14.0";
constexpr const char* kFirmwareNode = "\\_SB_.PCI0.XHC_";

}  // namespace

// The shim must come before umockdev's library, whose wrappers call the C
// library directly (as umockdev-wrapper alone puts it, it would come after).
bool EmulatedUvcCamera::available() {
  if (!UmockdevBed::available() || !dlsym(RTLD_DEFAULT, "psrig_hil_openat_shim_loaded"))
    return false;
  const std::string preload = std::getenv("LD_PRELOAD");
  return preload.find("psrig_hil_openat_shim") < preload.find("libumockdev-preload");
}

EmulatedUvcCamera::EmulatedUvcCamera(UmockdevBed& bed, EmulatedUvcOptions options,
                                     FrameSource source)
    : options_(std::move(options)) {
  const std::string usb_device = std::string(kController) + "/usb1/1-" + options_.port;
  const std::string interface = usb_device + "/1-" + options_.port + ":1.0";
  interface_path_ = "/sys" + interface;
  // Parents first: the host controller, the USB device, its interface.
  bed.add_from_string("P: " + std::string(kController) +
                      "\nE: SUBSYSTEM=pci\nE: DRIVER=xhci_hcd\nA: vendor=0x8086\\n\n");
  // libcamera names the camera after the first device up the tree that
  // firmware describes.
  const std::filesystem::path node =
      std::filesystem::path(bed.root()) / ("sys" + std::string(kController)) / "firmware_node";
  std::filesystem::create_directories(node);
  std::ofstream(node / "path") << kFirmwareNode << "\n";
  bed.add_from_string("P: " + usb_device +
                      "\nE: SUBSYSTEM=usb\nE: DEVTYPE=usb_device\nE: DRIVER=usb\nA: idVendor=" +
                      options_.vendor_id + "\\n\nA: idProduct=" + options_.product_id +
                      "\\n\nA: product=" + options_.card + "\\n\nA: removable=removable\\n\n");
  bed.add_from_string("P: " + interface +
                      "\nE: SUBSYSTEM=usb\nE: DEVTYPE=usb_interface\nE: DRIVER=uvcvideo\n"
                      "A: bInterfaceClass=0e\\n\nA: bInterfaceSubClass=01\\n\n");

  EmulatedV4l2Options video = options_.video;
  video.card = options_.card;
  video.driver = "uvcvideo";
  video.bus_info = "usb-0000:00:14.0-" + options_.port;
  video.parent = interface;
  video.pollable = true;
  video_ = std::make_unique<EmulatedV4l2Camera>(bed, video, std::move(source));

  // The graph uvcvideo builds, reduced to what a capture needs: the camera
  // terminal feeding the default video entity, which the video node's
  // interface points at.
  EmulatedMediaOptions media;
  media.name = "media" + std::to_string(video.minor);
  media.minor = video.minor;
  media.parent = interface_path_;
  media.driver = "uvcvideo";
  media.model = options_.card;
  media.bus_info = video.bus_info;
  media.graph.entities = {
      {.id = 1,
       .name = options_.card,
       .function = MEDIA_ENT_F_IO_V4L,
       .flags = MEDIA_ENT_FL_DEFAULT},
      {.id = 3, .name = "Camera 1", .function = MEDIA_ENT_F_CAM_SENSOR, .flags = 0},
  };
  media.graph.pads = {
      {.id = 2, .entity_id = 1, .flags = MEDIA_PAD_FL_SINK, .index = 0},
      {.id = 4, .entity_id = 3, .flags = MEDIA_PAD_FL_SOURCE, .index = 0},
  };
  media.graph.interfaces = {
      {.id = 5, .type = MEDIA_INTF_T_V4L_VIDEO, .major = 81, .minor = video.minor},
  };
  media.graph.links = {
      {.id = 6,
       .source_id = 4,
       .sink_id = 2,
       .flags = MEDIA_LNK_FL_DATA_LINK | MEDIA_LNK_FL_ENABLED | MEDIA_LNK_FL_IMMUTABLE},
      {.id = 7,
       .source_id = 5,
       .sink_id = 1,
       .flags = MEDIA_LNK_FL_INTERFACE_LINK | MEDIA_LNK_FL_ENABLED | MEDIA_LNK_FL_IMMUTABLE},
  };
  media_ = std::make_unique<EmulatedMediaDevice>(bed, std::move(media));
  // The class device's link to its parent, which umockdev does not make:
  // libcamera resolves it to find the USB device.
  std::filesystem::create_directory_symlink(
      "../../../1-" + options_.port + ":1.0",
      std::filesystem::path(bed.root()) / video_->syspath().substr(1) / "device");
  // As the kernel and udevd would have it: media is a bus, and udevd has
  // seen both nodes.
  bed.add_bus_link("media", media_->syspath());
  bed.add_udev_entry(81, options_.video.minor);
  bed.add_udev_entry(media_->major(), media_->minor());
}

std::string EmulatedUvcCamera::camera_id() const {
  // libcamera 0.0.3 keeps the configuration and interface after the port.
  return std::string(kFirmwareNode) + "-" + options_.port + ":1.0-" + options_.vendor_id + ":" +
         options_.product_id;
}

// In uvcvideo's order (uvc_unregister_video): the video node first, the
// media device last. libcamera learns of the unplug from the media device's
// "remove" uevent and then takes the camera for stopped (0.0.3 sets it
// Configured); a frame completing after that aborts the process ("Trying to
// complete a request when stopped"), which the kernel's order rules out:
// by then every request to the video node fails with ENODEV.
void EmulatedUvcCamera::unplug() {
  video_->unplug();
  media_->unplug();
}

}  // namespace psrig::test
