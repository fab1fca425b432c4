// The libcamera backend without a camera: the formats it maps onto the
// shared conversions, and the error a rig with no camera gets. With a
// camera attached, a real capture runs (skipped otherwise).

#include "psrig/cameras/libcamera_camera.h"

#include <chrono>

#include <gtest/gtest.h>

namespace psrig::cameras {
namespace {

TEST(LibcameraFormats, MapOntoTheV4l2LayoutsWithTheSameBytes) {
  const auto name = [](const std::string& libcamera) {
    const auto format = v4l2_format_for_libcamera(libcamera);
    return format ? std::string(format->name) : std::string("none");
  };
  EXPECT_EQ(name("SRGGB10_CSI2P"), "SRGGB10P");
  EXPECT_EQ(name("SBGGR12_CSI2P"), "SBGGR12P");
  EXPECT_EQ(name("SGRBG10"), "SGRBG10");
  EXPECT_EQ(name("SGBRG8"), "SGBRG8");
  EXPECT_EQ(name("R8"), "GREY");
  EXPECT_EQ(name("R16"), "Y16");
  EXPECT_EQ(name("RGB888"), "BGR24");  // DRM's RGB888 is B, G, R in memory
  EXPECT_EQ(name("BGR888"), "RGB24");
  EXPECT_EQ(name("YUYV"), "YUYV");
  EXPECT_EQ(name("NV12"), "none");  // two planes: not taken
  EXPECT_TRUE(v4l2_format_for_libcamera("SRGGB12_CSI2P")->linear);
  EXPECT_FALSE(v4l2_format_for_libcamera("RGB888")->linear);
}

TEST(LibcameraCamera, NoCameraIsAClearError) {
  auto cameras = list_libcamera_cameras();
  ASSERT_TRUE(cameras) << cameras.error().describe();
  if (!cameras->empty()) GTEST_SKIP() << "a libcamera camera is attached";
  auto camera = open_libcamera_camera({});
  ASSERT_FALSE(camera);
  const std::string message = camera.error().describe();
  EXPECT_NE(message.find("no camera found"), std::string::npos) << message;
  EXPECT_NE(message.find("psrig devices"), std::string::npos) << message;
}

TEST(LibcameraCamera, CapturesFromARealCamera) {
  auto cameras = list_libcamera_cameras();
  if (!cameras || cameras->empty()) GTEST_SKIP() << "no libcamera camera attached";
  config::CameraConfig settings;
  settings.backend = "libcamera";
  settings.device = "";
  settings.exposure_us = 10000;
  auto camera = open_libcamera_camera(settings);
  ASSERT_TRUE(camera) << camera.error().describe();
  ASSERT_TRUE((*camera)->configure(settings)) << (*camera)->describe();
  ASSERT_TRUE((*camera)->start());
  std::uint64_t last = 0;
  for (int i = 0; i < 4; ++i) {
    auto frame = (*camera)->grab(std::chrono::seconds(2));
    ASSERT_TRUE(frame) << frame.error().describe();
    EXPECT_FALSE(frame->image.empty());
    EXPECT_LT(frame->exposure_start, frame->exposure_end);
    if (i > 0) {
      EXPECT_GT(frame->sequence, last);
    }
    last = frame->sequence;
  }
  EXPECT_TRUE((*camera)->stop());
}

}  // namespace
}  // namespace psrig::cameras
