// The libcamera camera backend against a USB Video Class camera emulated in
// user space: libcamera 0.0.3 enumerates it through udev (umockdev's), its
// uvcvideo pipeline handler reads the media graph, opens the video node,
// sets its controls, exports and imports dmabufs and waits for frames in
// its own event loop's ppoll() on the node; the frames are the simulated
// world under its LEDs. Skips unless run under umockdev's preload library
// with the openat shim (ctest runs it so; tests/README.md).

#include <chrono>
#include <filesystem>
#include <linux/videodev2.h>
#include <memory>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "emulated_uvc_camera.h"
#include "psrig/cameras/camera.h"
#include "psrig/cameras/libcamera_camera.h"
#include "psrig/rig/open_devices.h"
#include "psrig/rig/rig.h"
#include "psrig/rig/scan_sequencer.h"
#include "psrig/sim/scene_truth.h"
#include "psrig/sim/sensor.h"
#include "psrig/sim/world.h"
#include "shipped_swatch.h"
#include "started_camera.h"
#include "test_support.h"
#include "umockdev_bed.h"

namespace psrig::cameras {
namespace {

using namespace std::chrono_literals;
using test::EmulatedUvcCamera;
using test::FrameRequest;
using test::open_started;

#define SKIP_WITHOUT_EMULATION()                                                            \
  if (!EmulatedUvcCamera::available())                                                      \
  GTEST_SKIP() << "needs LD_PRELOAD=libpsrig_hil_openat_shim.so:libumockdev-preload.so.0, " \
                  "in that order (ctest runs it so)"

constexpr int kSensorWidth = 64;
constexpr int kSensorHeight = 48;
constexpr const char* kModel = "psrig UVC camera";

config::RigConfig libcamera_config() {
  config::RigConfig c;
  c.source = "libcamera_hil_test.toml";
  c.lights.backend = "sim";
  c.camera.backend = "libcamera";
  c.camera.device = "";  // the first
  c.camera.format = "auto";
  c.camera.width = kSensorWidth;
  c.camera.height = kSensorHeight;
  c.camera.exposure_us = 5000;
  c.camera.gain = 1.0;
  c.sim.width = kSensorWidth;
  c.sim.height = kSensorHeight;
  c.sim.bit_depth = 8;  // GREY carries it whole
  c.sim.black_level = 4;
  return c;
}

// The simulated world, its LEDs and sensor, and an emulated UVC camera
// that renders the world under whatever the LEDs did during each exposure.
struct EmulatedRig {
  explicit EmulatedRig(std::vector<std::uint32_t> formats = {V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_GREY})
      : camera(bed,
               {.card = kModel,
                .video = {.formats = std::move(formats),
                          .sizes = {{kSensorWidth, kSensorHeight}, {32, 24}},
                          .frame_interval = 20ms,
                          .readout = 2ms}},
               [this](const FrameRequest& r) { return render(r); }) {}

  cv::Mat render(const FrameRequest& r) const {
    sim::SensorSettings settings;
    settings.exposure_us = r.exposure_us;
    settings.gain = r.gain;
    settings.channels = r.channels;
    return sensor.expose(*world, r.exposure_start, settings, r.sequence);
  }

  config::RigConfig config = libcamera_config();
  std::shared_ptr<sim::World> world = test::made(sim::World::attach(config));
  sim::Sensor sensor{config.sim, 5};
  test::UmockdevBed bed;
  EmulatedUvcCamera camera;
};

// The device's frame a grabbed one came from, by its exposure: the stamp
// is the start of exposure, in microseconds, which the backend dates a
// whole exposure earlier.
const FrameRequest* truth_of(const std::vector<FrameRequest>& delivered, const Frame& frame) {
  for (const auto& d : delivered) {
    const auto start = frame.exposure_start + std::chrono::microseconds(frame.exposure_us);
    if (d.exposure_start - start < 2us && start - d.exposure_start < 2us) return &d;
  }
  return nullptr;
}

TEST(LibcameraHil, FindsTheEmulatedUvcCameraByItsId) {
  SKIP_WITHOUT_EMULATION();
  EmulatedRig rig;
  auto cameras = list_libcamera_cameras();
  ASSERT_TRUE(cameras) << cameras.error().describe();
  ASSERT_EQ(cameras->size(), 1U);
  EXPECT_EQ(cameras->front(), rig.camera.camera_id() + " (" + kModel + ")");

  auto config = rig.config;
  config.camera.device = rig.camera.camera_id();
  auto camera = psrig::rig::open_camera(config);
  ASSERT_TRUE(camera) << camera.error().describe();
  EXPECT_NE((*camera)->describe().find(kModel), std::string::npos) << (*camera)->describe();
  EXPECT_GT(rig.camera.media().requests(), 0);  // the media graph was read

  config.camera.device = "no-such-camera";
  camera.value().reset();  // one user at a time
  auto missing = psrig::rig::open_camera(config);
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().key, "camera.device");
  EXPECT_NE(missing.error().message.find(rig.camera.camera_id()), std::string::npos)
      << missing.error().describe();
}

TEST(LibcameraHil, CapturesTheSimulatedSwatchUnderEachLed) {
  SKIP_WITHOUT_EMULATION();
  EmulatedRig rig;
  auto camera = open_started(rig.config);
  ASSERT_NE(camera, nullptr);
  // "auto" takes the linear format over YUYV; the controls went through
  // the pipeline handler to the node: manual exposure, in 100 us.
  EXPECT_EQ(rig.camera.video().pixel_format(), V4L2_PIX_FMT_GREY);
  EXPECT_EQ(rig.camera.video().size(), cv::Size(kSensorWidth, kSensorHeight));
  EXPECT_NE(camera->describe().find("GREY"), std::string::npos) << camera->describe();

  const auto& leds = rig.world->leds();
  for (int led = 0; led < leds->channel_count(); ++led) {
    SCOPED_TRACE("LED " + std::to_string(led));
    leds->all_off();
    const auto lit = Clock::now();
    leds->set_led(led, true, 1.0, lit);
    // The first frame exposed wholly after the switch.
    Frame frame;
    for (int i = 0; i < 20; ++i) {
      auto grabbed = camera->grab(1s);
      ASSERT_TRUE(grabbed) << grabbed.error().describe();
      frame = std::move(*grabbed);
      if (frame.exposure_start >= lit) break;
    }
    ASSERT_GE(frame.exposure_start, lit);
    ASSERT_EQ(frame.image.type(), CV_8UC1);
    ASSERT_EQ(frame.image.size(), cv::Size(kSensorWidth, kSensorHeight));
    EXPECT_EQ(frame.exposure_us, 5000);
    EXPECT_EQ(frame.white_level, 255);

    const auto delivered = rig.camera.video().delivered();
    const FrameRequest* truth = truth_of(delivered, frame);
    ASSERT_NE(truth, nullptr);
    EXPECT_EQ(truth->exposure_us, 5000);  // as psrig asked, through libcamera
    // Lit by this LED alone for the whole exposure...
    const auto weights = rig.world->exposure_weights(truth->exposure_start, truth->exposure_end);
    for (int other = 0; other < static_cast<int>(weights.size()); ++other)
      EXPECT_DOUBLE_EQ(weights[other], other == led ? 1.0 : 0.0) << "LED " << other;
    // ...and the pixels are the simulated sensor's render of it, exactly.
    cv::Mat expected;
    rig.render(*truth).convertTo(expected, CV_8U);
    EXPECT_EQ(cv::norm(frame.image, expected, cv::NORM_INF), 0.0);
    EXPECT_GT(cv::mean(frame.image)[0], 10.0);  // lit, not black
  }
  leds->all_off();
  EXPECT_EQ(rig.camera.video().control(V4L2_CID_EXPOSURE_AUTO), V4L2_EXPOSURE_MANUAL);
  EXPECT_EQ(rig.camera.video().control(V4L2_CID_EXPOSURE_ABSOLUTE), 50);
  EXPECT_FALSE(leds->log().overlap());
  EXPECT_TRUE(camera->stop());
  EXPECT_FALSE(rig.camera.video().streaming());
}

TEST(LibcameraHil, AutoTakesTheDeepestLinearFormatOffered) {
  SKIP_WITHOUT_EMULATION();
  EmulatedRig rig({V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_GREY, V4L2_PIX_FMT_SRGGB12});
  auto camera = open_started(rig.config);
  ASSERT_NE(camera, nullptr);
  EXPECT_EQ(rig.camera.video().pixel_format(), V4L2_PIX_FMT_SRGGB12);
  auto frame = camera->grab(1s);
  ASSERT_TRUE(frame) << frame.error().describe();
  EXPECT_EQ(frame->white_level, 4095);
  EXPECT_EQ(frame->image.type(), CV_16UC3);  // demosaiced
  EXPECT_EQ(frame->encoding, formats::Encoding::linear);
}

TEST(LibcameraHil, ConfigurationErrorsNameTheCameraAndTheKey) {
  SKIP_WITHOUT_EMULATION();
  EmulatedRig rig;
  auto config = rig.config;
  config.camera.format = "Y16";
  auto not_offered = psrig::rig::open_camera(config);
  ASSERT_FALSE(not_offered);
  // Bad input naming the key, as the v4l2 backend says it.
  EXPECT_EQ(not_offered.error().kind, ErrorKind::bad_input) << not_offered.error().describe();
  EXPECT_EQ(not_offered.error().key, "camera.format") << not_offered.error().describe();
  EXPECT_NE(not_offered.error().describe().find("does not offer Y16"), std::string::npos)
      << not_offered.error().describe();
  EXPECT_NE(not_offered.error().describe().find(rig.camera.camera_id()), std::string::npos)
      << not_offered.error().describe();
}

TEST(LibcameraHil, FramesComeInOrderAtTheDevicesPace) {
  SKIP_WITHOUT_EMULATION();
  EmulatedRig rig;
  auto camera = open_started(rig.config);
  ASSERT_NE(camera, nullptr);
  std::vector<Frame> frames;
  for (int i = 0; i < 6; ++i) {
    auto frame = camera->grab(1s);
    ASSERT_TRUE(frame) << frame.error().describe();
    frames.push_back(std::move(*frame));
  }
  for (std::size_t i = 1; i < frames.size(); ++i) {
    EXPECT_GT(frames[i].sequence, frames[i - 1].sequence);
    // Sequence gaps are frames dropped while no buffer was queued.
    EXPECT_GE(frames[i].exposure_start - frames[i - 1].exposure_start,
              (frames[i].sequence - frames[i - 1].sequence) * 20ms - 2us);
  }
  EXPECT_LE(frames.back().exposure_end, Clock::now());
  // Stopped and started again, it streams again.
  ASSERT_TRUE(camera->stop());
  ASSERT_TRUE(camera->start());
  auto again = camera->grab(1s);
  EXPECT_TRUE(again) << again.error().describe();
}

TEST(LibcameraHil, AStalledCameraTimesOutNamingIt) {
  SKIP_WITHOUT_EMULATION();
  EmulatedRig rig;
  auto camera = open_started(rig.config);
  ASSERT_NE(camera, nullptr);
  ASSERT_TRUE(camera->grab(1s));
  rig.camera.video().stall();
  Result<Frame> frame;
  for (int i = 0; i < 8 && frame; ++i)  // frames done before the stall may still come
    frame = camera->grab(150ms);
  ASSERT_FALSE(frame);
  EXPECT_NE(frame.error().message.find("no frame within 150 ms"), std::string::npos)
      << frame.error().describe();
  EXPECT_NE(frame.error().describe().find(rig.camera.camera_id()), std::string::npos)
      << frame.error().describe();
  rig.camera.video().resume();
  auto again = camera->grab(1s);
  EXPECT_TRUE(again) << again.error().describe();
}

TEST(LibcameraHil, AnUnpluggedCameraIsAClearErrorNamingIt) {
  SKIP_WITHOUT_EMULATION();
  EmulatedRig rig;
  auto camera = open_started(rig.config);
  ASSERT_NE(camera, nullptr);
  ASSERT_TRUE(camera->grab(1s));

  rig.camera.unplug();
  Result<Frame> frame;
  const auto began = Clock::now();
  for (int i = 0; i < 8 && frame; ++i)  // frames done before the unplug may still come
    frame = camera->grab(2s);
  ASSERT_FALSE(frame);
  const std::string message = frame.error().describe();
  EXPECT_NE(message.find("the camera is gone"), std::string::npos) << message;
  EXPECT_NE(message.find(rig.camera.camera_id()), std::string::npos) << message;
  EXPECT_NE(message.find(kModel), std::string::npos) << message;
  EXPECT_LT(Clock::now() - began, 1s);  // told by udev, not by a timeout
  auto again = camera->grab(2s);
  ASSERT_FALSE(again);
  EXPECT_NE(again.error().describe().find("the camera is gone"), std::string::npos);
  EXPECT_TRUE(camera->stop());
  camera.reset();
  // And a camera that is gone is not found again.
  auto reopened = psrig::rig::open_camera(rig.config);
  ASSERT_FALSE(reopened);
  EXPECT_NE(reopened.error().describe().find("no camera found"), std::string::npos)
      << reopened.error().describe();
}

// Whole scans through libcamera: the simulated LEDs (the sim light
// backend, the world's own) and the emulated UVC camera, 12-bit Bayer.
struct ScanRig {
  static config::RigConfig scan_config() {
    config::RigConfig c;
    c.source = "libcamera_hil_scan.toml";
    c.lights.backend = "sim";
    c.camera.backend = "libcamera";
    c.camera.device = "";
    c.camera.format = "auto";
    c.camera.width = 256;
    c.camera.height = 192;
    c.camera.exposure_us = 20000;
    c.camera.frames_average = 2;
    c.camera.frames_discard = 0;
    c.camera.timeout_ms = 300;
    c.capture.settle_ms = 5;
    c.sim.width = 256;
    c.sim.height = 192;
    return c;
  }

  config::RigConfig config = scan_config();
  std::shared_ptr<sim::World> world = test::made(sim::World::attach(config));
  sim::Sensor sensor{config.sim, 11};
  test::UmockdevBed bed;
  EmulatedUvcCamera camera{bed,
                           {.card = kModel,
                            .video = {.formats = {V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_SRGGB12},
                                      .sizes = {{256, 192}},
                                      .frame_interval = 35ms,
                                      .readout = 15ms}},
                           [this](const FrameRequest& r) {
                             sim::SensorSettings settings;
                             settings.exposure_us = r.exposure_us;
                             settings.gain = r.gain;
                             settings.channels = r.channels;
                             return sensor.expose(*world, r.exposure_start, settings, r.sequence);
                           }};

  rig::ScanRequest request_into(const test::TempDir& dir) const {
    rig::ScanRequest request;
    request.directory = dir / "scan";
    request.sample_id = "HIL-LIBCAMERA";
    return request;
  }

  // The emulated camera shows the simulated world, so its scans carry the
  // world's answer as a simulated camera's do.
  [[nodiscard]] Result<rig::Rig> open() const {
    rig::RigWrappers truth;
    truth.camera = [this](std::unique_ptr<cameras::Camera> opened) {
      return sim::with_scene_truth(std::move(opened), world, config.sim.swatch_rotation_deg);
    };
    return rig::open_rig(config, true, truth);
  }
};

TEST(LibcameraHil, AScanThroughLibcameraRecoversTheSwatch) {
  SKIP_WITHOUT_EMULATION();
  test::TempDir dir;
  ScanRig emulated;
  auto rig = emulated.open();
  ASSERT_TRUE(rig) << rig.error().describe();
  rig::ScanSequencer sequencer(emulated.config, *rig->lights, *rig->camera);
  auto outcome = sequencer.capture(emulated.request_into(dir));
  ASSERT_TRUE(outcome) << outcome.error().describe();
  ASSERT_TRUE(outcome->maps);
  const auto& error = outcome->maps->report["ground_truth"]["angular_error_deg"];
  // As the V4L2 backend's scan of the same Bayer sensor (scan_hil_test).
  EXPECT_LE(error["mean"].get<double>(), 2.5) << error.dump();
  EXPECT_LE(error["median"].get<double>(), 1.2) << error.dump();
  EXPECT_EQ(outcome->timing.frames_kept, 8);
  EXPECT_EQ(emulated.camera.video().control(V4L2_CID_EXPOSURE_ABSOLUTE), 200);
  EXPECT_FALSE(emulated.world->leds()->log().overlap());
  EXPECT_TRUE(emulated.world->leds()->leds_on().empty());
}

TEST(LibcameraHil, ACameraUnpluggedMidScanEndsItWithAllLedsOff) {
  SKIP_WITHOUT_EMULATION();
  test::TempDir dir;
  ScanRig emulated;
  auto rig = emulated.open();
  ASSERT_TRUE(rig) << rig.error().describe();
  rig::ScanSequencer sequencer(emulated.config, *rig->lights, *rig->camera);
  auto outcome =
      sequencer.capture(emulated.request_into(dir), [&](const rig::ScanProgress& progress) {
        if (progress.step == "light 3 of 3") emulated.camera.unplug();
      });
  ASSERT_FALSE(outcome);
  const std::string message = outcome.error().describe();
  EXPECT_NE(message.find(emulated.camera.camera_id()), std::string::npos) << message;
  EXPECT_NE(message.find("the camera is gone"), std::string::npos) << message;
  EXPECT_FALSE(std::filesystem::exists(dir / "scan"));
  EXPECT_FALSE(rig->lights->log().overlap());
  EXPECT_TRUE(rig->lights->log().on_now().empty());
  EXPECT_TRUE(emulated.world->leds()->leds_on().empty());
}

}  // namespace
}  // namespace psrig::cameras
