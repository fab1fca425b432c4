// The v4l2 camera backend, opened through the camera factory, against a
// V4L2 capture device emulated in user space (umockdev): formats, controls,
// frame timing, and the ways a real camera fails.

#include <chrono>
#include <cstdint>
#include <linux/videodev2.h>
#include <string>
#include <sys/stat.h>
#include <vector>

#include <gtest/gtest.h>

#include "emulated_v4l2_camera.h"
#include "psrig/cameras/camera.h"
#include "psrig/cameras/v4l2_formats.h"
#include "psrig/rig/open_devices.h"
#include "started_camera.h"
#include "umockdev_bed.h"

namespace psrig::cameras {
namespace {

using namespace std::chrono_literals;
using test::EmulatedV4l2Camera;
using test::EmulatedV4l2Options;
using test::FrameRequest;
using test::open_started;

#define SKIP_WITHOUT_UMOCKDEV() \
  if (!test::UmockdevBed::available()) GTEST_SKIP() << "not under umockdev-wrapper"

constexpr int kWidth = 32;
constexpr int kHeight = 24;

config::RigConfig v4l2_config(const std::string& device, const std::string& format = "auto") {
  config::RigConfig rig;
  rig.source = "v4l2_hil_test.toml";
  rig.camera.backend = "v4l2";
  rig.camera.device = device;
  rig.camera.format = format;
  rig.camera.width = 0;  // the largest offered
  rig.camera.height = 0;
  rig.camera.exposure_us = 5000;
  rig.camera.gain = 1.0;
  return rig;
}

// The factory, as the rig opens its camera; started.
Frame grab_ok(Camera& camera, std::chrono::milliseconds timeout = 1000ms) {
  auto frame = camera.grab(timeout);
  EXPECT_TRUE(frame.has_value()) << (frame ? "" : frame.error().describe());
  return frame.value_or(Frame{});
}

// Ramps that bilinear demosaicing reproduces exactly away from the border:
// every value is the average of its neighbours on each side.
int ramp(int channel, int x, int y) {
  switch (channel) {
    case 0:
      return 10 + 2 * x;  // blue
    case 1:
      return 20 + 2 * y;  // green
    default:
      return 200 - 2 * x - 2 * y;  // red
  }
}
int grey_ramp(int x, int y) {
  return 10 + 2 * x + 4 * y;
}

// The scene at the format's bit depth: the 8-bit ramps scaled up.
cv::Mat ramp_scene(const FrameRequest& r) {
  const int scale = 1 << (r.bits - 8);
  cv::Mat scene(r.height, r.width, r.channels == 1 ? CV_16UC1 : CV_16UC3);
  for (int y = 0; y < r.height; ++y)
    for (int x = 0; x < r.width; ++x) {
      if (r.channels == 1) {
        scene.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(scale * grey_ramp(x, y));
        continue;
      }
      auto& p = scene.at<cv::Vec<std::uint16_t, 3>>(y, x);
      for (int c = 0; c < 3; ++c)
        p[c] = static_cast<std::uint16_t>(scale * ramp(c, x, y));
    }
  return scene;
}

int sample(const cv::Mat& m, int x, int y, int c) {
  if (m.depth() == CV_8U)
    return m.channels() == 1 ? m.at<std::uint8_t>(y, x) : m.at<cv::Vec3b>(y, x)[c];
  return m.channels() == 1 ? m.at<std::uint16_t>(y, x) : m.at<cv::Vec<std::uint16_t, 3>>(y, x)[c];
}

struct FormatCase {
  std::uint32_t fourcc;
  int bits;
  int channels;
  int tolerance;  // in 8-bit codes
  int border;     // pixels left out at the edges (demosaicing guesses there)
};

const FormatCase kFormatCases[] = {
    {V4L2_PIX_FMT_GREY, 8, 1, 0, 0},      {V4L2_PIX_FMT_Y10, 10, 1, 0, 0},
    {V4L2_PIX_FMT_Y12, 12, 1, 0, 0},      {V4L2_PIX_FMT_Y16, 16, 1, 0, 0},
    {V4L2_PIX_FMT_RGB24, 8, 3, 0, 0},     {V4L2_PIX_FMT_BGR24, 8, 3, 0, 0},
    {V4L2_PIX_FMT_YUYV, 8, 3, 4, 0},      {V4L2_PIX_FMT_SBGGR8, 8, 3, 0, 1},
    {V4L2_PIX_FMT_SGBRG8, 8, 3, 0, 1},    {V4L2_PIX_FMT_SGRBG8, 8, 3, 0, 1},
    {V4L2_PIX_FMT_SRGGB8, 8, 3, 0, 1},    {V4L2_PIX_FMT_SBGGR10, 10, 3, 0, 1},
    {V4L2_PIX_FMT_SRGGB12, 12, 3, 0, 1},  {V4L2_PIX_FMT_SBGGR10P, 10, 3, 0, 1},
    {V4L2_PIX_FMT_SGBRG10P, 10, 3, 0, 1}, {V4L2_PIX_FMT_SGRBG10P, 10, 3, 0, 1},
    {V4L2_PIX_FMT_SRGGB10P, 10, 3, 0, 1}, {V4L2_PIX_FMT_SBGGR12P, 12, 3, 0, 1},
    {V4L2_PIX_FMT_SGBRG12P, 12, 3, 0, 1}, {V4L2_PIX_FMT_SGRBG12P, 12, 3, 0, 1},
    {V4L2_PIX_FMT_SRGGB12P, 12, 3, 0, 1},
};

TEST(V4l2Hil, EveryFormatIsNegotiatedMappedAndConvertedToTheScene) {
  SKIP_WITHOUT_UMOCKDEV();
  test::UmockdevBed bed;
  EmulatedV4l2Options options;
  for (const auto& c : kFormatCases)
    options.formats.push_back(c.fourcc);
  options.sizes = {{kWidth, kHeight}, {16, 12}};
  options.line_padding = 12;  // lines longer than their pixels: the stride must be honoured
  EmulatedV4l2Camera device(bed, options, ramp_scene);

  for (const auto& c : kFormatCases) {
    const std::string name = fourcc_to_string(c.fourcc);
    SCOPED_TRACE(name);
    auto camera = open_started(v4l2_config(device.devnode(), name));
    ASSERT_NE(camera, nullptr);
    EXPECT_EQ(device.pixel_format(), c.fourcc);
    EXPECT_EQ(device.size(), cv::Size(kWidth, kHeight));  // the largest offered
    const Frame frame = grab_ok(*camera);
    ASSERT_FALSE(frame.image.empty());
    EXPECT_EQ(frame.image.size(), cv::Size(kWidth, kHeight));
    EXPECT_EQ(frame.image.channels(), c.channels);
    EXPECT_EQ(frame.image.depth(), c.bits == 8 ? CV_8U : CV_16U);
    EXPECT_EQ(frame.white_level, (1 << c.bits) - 1);
    // An ISP's RGB and YUYV are gamma-encoded; sensor data is linear.
    const bool encoded = c.fourcc == V4L2_PIX_FMT_RGB24 || c.fourcc == V4L2_PIX_FMT_BGR24 ||
                         c.fourcc == V4L2_PIX_FMT_YUYV;
    EXPECT_EQ(frame.encoding, encoded ? formats::Encoding::srgb : formats::Encoding::linear);
    EXPECT_NE(camera->describe().find(name), std::string::npos) << camera->describe();

    const int scale = 1 << (c.bits - 8);
    int wrong = 0;
    for (int y = c.border; y < kHeight - c.border; ++y)
      for (int x = c.border; x < kWidth - c.border; ++x)
        for (int ch = 0; ch < c.channels; ++ch) {
          const int want = scale * (c.channels == 1 ? grey_ramp(x, y) : ramp(ch, x, y));
          const int got = sample(frame.image, x, y, ch);
          if (std::abs(got - want) > c.tolerance * scale && wrong++ < 3)
            ADD_FAILURE() << "(" << x << ", " << y << ") channel " << ch << ": got " << got
                          << ", want " << want;
        }
    EXPECT_EQ(wrong, 0);
    EXPECT_TRUE(camera->stop().has_value());
  }
}

TEST(V4l2Hil, AutoFormatTakesTheDeepestLinearOneOffered) {
  SKIP_WITHOUT_UMOCKDEV();
  test::UmockdevBed bed;
  EmulatedV4l2Options options;
  options.formats = {V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_GREY, V4L2_PIX_FMT_SRGGB10P,
                     V4L2_PIX_FMT_RGB24};
  EmulatedV4l2Camera device(bed, options, ramp_scene);
  auto camera = open_started(v4l2_config(device.devnode(), "auto"));
  ASSERT_NE(camera, nullptr);
  EXPECT_EQ(device.pixel_format(), V4L2_PIX_FMT_SRGGB10P);
  EXPECT_EQ(grab_ok(*camera).white_level, 1023);
}

TEST(V4l2Hil, ExposureAndGainAreSetManuallyAndReadBack) {
  SKIP_WITHOUT_UMOCKDEV();
  test::UmockdevBed bed;
  EmulatedV4l2Options options;
  options.gain = {V4L2_CID_ANALOGUE_GAIN, 16, 255, 1, 16};
  options.frame_interval = 20ms;  // room for the exposure
  EmulatedV4l2Camera device(bed, options, ramp_scene);
  auto rig = v4l2_config(device.devnode());
  rig.camera.exposure_us = 12345;  // the control counts 100 us: 123
  rig.camera.gain = 2.5;           // unity is the default, 16: 40
  auto camera = open_started(rig);
  ASSERT_NE(camera, nullptr);

  EXPECT_EQ(device.control(V4L2_CID_EXPOSURE_AUTO), V4L2_EXPOSURE_MANUAL);
  EXPECT_EQ(device.control(V4L2_CID_EXPOSURE_ABSOLUTE), 123);
  EXPECT_EQ(device.control(V4L2_CID_ANALOGUE_GAIN), 40);
  const Frame frame = grab_ok(*camera);
  EXPECT_EQ(frame.exposure_us, 12300);
  EXPECT_DOUBLE_EQ(frame.gain, 2.5);
  EXPECT_EQ(frame.exposure_end - frame.exposure_start, 12300us);
  // And the device exposed the frame so.
  const auto delivered = device.delivered();
  ASSERT_FALSE(delivered.empty());
  EXPECT_EQ(delivered.back().exposure_us, 12300);
  EXPECT_DOUBLE_EQ(delivered.back().gain, 2.5);
}

TEST(V4l2Hil, ExposureAndGainOutOfReachAreClampedToWhatTheDeviceTakes) {
  SKIP_WITHOUT_UMOCKDEV();
  test::UmockdevBed bed;
  EmulatedV4l2Options options;
  options.exposure = {V4L2_CID_EXPOSURE_ABSOLUTE, 1, 300, 1, 100};  // at most 30 ms
  options.gain = {V4L2_CID_GAIN, 16, 64, 4, 16};                    // steps of 0.25
  options.frame_interval = 30ms;
  EmulatedV4l2Camera device(bed, options, ramp_scene);
  auto rig = v4l2_config(device.devnode());
  rig.camera.exposure_us = 100000;
  rig.camera.gain = 1.3;
  auto camera = open_started(rig);
  ASSERT_NE(camera, nullptr);
  EXPECT_EQ(device.control(V4L2_CID_EXPOSURE_ABSOLUTE), 300);
  EXPECT_EQ(device.control(V4L2_CID_GAIN), 20);
  const Frame frame = grab_ok(*camera);
  EXPECT_EQ(frame.exposure_us, 30000);
  EXPECT_DOUBLE_EQ(frame.gain, 1.25);
  EXPECT_NE(camera->describe().find("exposure 30000 us"), std::string::npos) << camera->describe();
}

TEST(V4l2Hil, SequenceAndStartOfExposureStampsAreTheDevicesAndMonotone) {
  SKIP_WITHOUT_UMOCKDEV();
  test::UmockdevBed bed;
  EmulatedV4l2Options options;
  options.first_sequence = 0xffff'fffe;  // the driver's 32-bit count wraps on the way
  options.frame_interval = 10ms;
  EmulatedV4l2Camera device(bed, options, ramp_scene);
  auto camera = open_started(v4l2_config(device.devnode()));
  ASSERT_NE(camera, nullptr);

  std::vector<Frame> frames;
  for (int i = 0; i < 8; ++i)
    frames.push_back(grab_ok(*camera));
  const auto delivered = device.delivered();
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const Frame& f = frames[i];
    SCOPED_TRACE("frame " + std::to_string(i));
    // The device's frame with the same (32-bit) sequence number.
    const FrameRequest* truth = nullptr;
    for (const auto& d : delivered)
      if (d.sequence == static_cast<std::uint32_t>(f.sequence)) truth = &d;
    ASSERT_NE(truth, nullptr);
    // Buffer stamps have microseconds: the start is at most 1 us early.
    EXPECT_LE(f.exposure_start, truth->exposure_start);
    EXPECT_GT(f.exposure_start, truth->exposure_start - 1us);
    EXPECT_EQ(f.exposure_end - f.exposure_start, 5000us);
    EXPECT_EQ(f.frame_interval, 10ms);  // as VIDIOC_G_PARM says
    EXPECT_LE(f.exposure_end, Clock::now());
    if (i == 0) continue;
    EXPECT_GT(f.sequence, frames[i - 1].sequence);
    EXPECT_GE(f.exposure_start - frames[i - 1].exposure_start,
              (f.sequence - frames[i - 1].sequence) * 10ms - 1us);
  }
  EXPECT_EQ(frames.front().sequence, 0xffff'fffeu);  // frame 0 always finds a queued buffer
  EXPECT_GT(frames.back().sequence, 0xffff'ffffu);   // counted on past the wrap, not back to 0
}

TEST(V4l2Hil, EndOfFrameStampsPutTheExposureNoLaterThanItWas) {
  SKIP_WITHOUT_UMOCKDEV();
  test::UmockdevBed bed;
  EmulatedV4l2Options options;
  options.start_of_exposure_stamps = false;
  options.frame_interval = 10ms;
  options.readout = 3ms;
  EmulatedV4l2Camera device(bed, options, ramp_scene);
  auto camera = open_started(v4l2_config(device.devnode()));
  ASSERT_NE(camera, nullptr);

  for (int i = 0; i < 4; ++i) {
    const Frame f = grab_ok(*camera);
    const auto delivered = device.delivered();
    const FrameRequest* truth = nullptr;
    for (const auto& d : delivered)
      if (d.sequence == static_cast<std::uint32_t>(f.sequence)) truth = &d;
    ASSERT_NE(truth, nullptr);
    // The stamp is the end of readout, which takes at most a frame interval
    // (as G_PARM says): the true start lies within that much after ours.
    EXPECT_LE(f.exposure_start, truth->exposure_start);
    EXPECT_GE(f.exposure_start, truth->exposure_start - 10ms - 1us);
  }
}

TEST(V4l2Hil, AStalledDeviceTimesOutNamingItAndRecovers) {
  SKIP_WITHOUT_UMOCKDEV();
  test::UmockdevBed bed;
  EmulatedV4l2Camera device(bed, {}, ramp_scene);
  auto camera = open_started(v4l2_config(device.devnode()));
  ASSERT_NE(camera, nullptr);
  grab_ok(*camera);

  device.stall();
  // Frames done before the stall may still wait in the queue.
  Result<Frame> frame;
  auto began = Clock::now();
  for (int i = 0; i < 8; ++i) {
    began = Clock::now();
    frame = camera->grab(150ms);
    if (!frame) break;
  }
  const auto waited = Clock::now() - began;
  ASSERT_FALSE(frame.has_value());
  EXPECT_EQ(frame.error().file, device.devnode());
  EXPECT_NE(frame.error().message.find("no frame within 150 ms"), std::string::npos)
      << frame.error().describe();
  EXPECT_NE(frame.error().message.find("camera.timeout_ms"), std::string::npos);
  EXPECT_GE(waited, 150ms);
  EXPECT_LT(waited, 1s);

  device.resume();
  grab_ok(*camera);
}

TEST(V4l2Hil, ADeviceUnpluggedMidStreamIsReportedAsVanished) {
  SKIP_WITHOUT_UMOCKDEV();
  test::UmockdevBed bed;
  EmulatedV4l2Camera device(bed, {}, ramp_scene);
  auto camera = open_started(v4l2_config(device.devnode()));
  ASSERT_NE(camera, nullptr);
  grab_ok(*camera);

  device.unplug();
  auto frame = camera->grab(500ms);
  ASSERT_FALSE(frame.has_value());
  EXPECT_EQ(frame.error().file, device.devnode());
  EXPECT_NE(frame.error().message.find("vanished"), std::string::npos) << frame.error().describe();
  auto again = camera->grab(500ms);  // and it stays gone, without waiting for a timeout
  ASSERT_FALSE(again.has_value());
  EXPECT_NE(again.error().message.find("vanished"), std::string::npos);
  EXPECT_TRUE(camera->stop().has_value());
  struct stat st {};
  EXPECT_NE(::stat(device.devnode().c_str(), &st), 0);  // gone from the testbed too
}

TEST(V4l2Hil, ConfigurationErrorsNameTheDeviceAndTheKey) {
  SKIP_WITHOUT_UMOCKDEV();
  test::UmockdevBed bed;
  EmulatedV4l2Options options;
  options.formats = {V4L2_PIX_FMT_GREY, V4L2_PIX_FMT_YUYV};
  EmulatedV4l2Camera device(bed, options, ramp_scene);

  auto not_offered = psrig::rig::open_camera(v4l2_config(device.devnode(), "Y16"));
  ASSERT_FALSE(not_offered.has_value());
  EXPECT_EQ(not_offered.error().key, "camera.format");
  EXPECT_EQ(not_offered.error().file, device.devnode());
  EXPECT_NE(not_offered.error().message.find("does not offer Y16"), std::string::npos)
      << not_offered.error().describe();
  EXPECT_NE(not_offered.error().message.find("YUYV"), std::string::npos);

  auto rig = v4l2_config(device.devnode(), "GREY");
  rig.camera.width = 640;
  rig.camera.height = 480;
  auto wrong_size = psrig::rig::open_camera(rig);
  ASSERT_FALSE(wrong_size.has_value());
  EXPECT_EQ(wrong_size.error().key, "camera.width");
  EXPECT_NE(wrong_size.error().message.find("32x24"), std::string::npos)
      << wrong_size.error().describe();

  auto missing = psrig::rig::open_camera(v4l2_config("/dev/psrig-no-such-video"));
  ASSERT_FALSE(missing.has_value());
  EXPECT_EQ(missing.error().key, "camera.device");
}

TEST(V4l2Hil, ExposureInDriverUnitsWithoutALineTimeIsRefusedByKey) {
  SKIP_WITHOUT_UMOCKDEV();
  test::UmockdevBed bed;
  EmulatedV4l2Options options;
  options.auto_exposure = false;
  options.exposure = {V4L2_CID_EXPOSURE, 4, 2000, 1,
                      1000};  // lines, and no pixel rate to say how long
  EmulatedV4l2Camera device(bed, options, ramp_scene);
  auto camera = psrig::rig::open_camera(v4l2_config(device.devnode()));
  ASSERT_FALSE(camera.has_value());
  EXPECT_EQ(camera.error().key, "camera.exposure_us");
  EXPECT_NE(camera.error().message.find("V4L2_CID_EXPOSURE"), std::string::npos)
      << camera.error().describe();
}

}  // namespace
}  // namespace psrig::cameras
