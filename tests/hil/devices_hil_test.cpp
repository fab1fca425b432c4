// `psrig devices` finds what an engineer plugged in: an emulated GPIO chip,
// V4L2 camera and USB strobe controller, named as rig.toml takes them.

#include <algorithm>
#include <linux/videodev2.h>

#include <gtest/gtest.h>

#include "emulated_gpio_chip.h"
#include "emulated_strobe_controller.h"
#include "emulated_v4l2_camera.h"
#include "psrig/cameras/camera_discovery.h"
#include "psrig/lights/device_discovery.h"
#include "umockdev_bed.h"

namespace psrig::test {
namespace {

TEST(DevicesHil, FindsTheChipTheCameraAndTheStrobeController) {
  if (!UmockdevBed::available()) GTEST_SKIP() << "not under umockdev-wrapper";
  UmockdevBed bed;
  EmulatedGpioChip chip(bed, {.name = "gpiochip0", .label = "rig-leds", .lines = 8});
  EmulatedV4l2Camera camera(
      bed, {.name = "video0", .formats = {V4L2_PIX_FMT_Y12, V4L2_PIX_FMT_SRGGB10P}},
      [](const FrameRequest& r) { return cv::Mat(r.height, r.width, CV_16UC1); });
  EmulatedStrobeController controller(bed);

  const auto chips = lights::find_gpio_chips();
  ASSERT_EQ(chips.size(), 1U);
  EXPECT_EQ(chips[0].path, "/dev/gpiochip0");
  EXPECT_EQ(chips[0].description, "label \"rig-leds\", 8 lines");

  const auto cameras = cameras::find_cameras();
  const auto v4l2 = std::find_if(cameras.begin(), cameras.end(),
                                 [](const auto& c) { return c.backend == "v4l2"; });
  ASSERT_NE(v4l2, cameras.end());
  EXPECT_EQ(v4l2->device, "/dev/video0");
  EXPECT_NE(v4l2->description.find("\"psrig emulated camera\""), std::string::npos)
      << v4l2->description;
  EXPECT_NE(v4l2->description.find("formats psrig takes: Y12 pRAA"), std::string::npos)
      << v4l2->description;

  const auto controllers = lights::find_usb_strobe_controllers(0x1209, 0x5053);
  ASSERT_EQ(controllers.size(), 1U);
  EXPECT_EQ(controllers[0].path, "001:002");
  EXPECT_NE(controllers[0].description.find("serial A17"), std::string::npos)
      << controllers[0].description;
  EXPECT_TRUE(lights::find_usb_strobe_controllers(0x1209, 0x0001).empty());
}

}  // namespace
}  // namespace psrig::test
