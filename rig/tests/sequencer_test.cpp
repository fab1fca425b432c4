// The scan sequencer: a simulated scan recovers the swatch's normals, stale
// frames never reach the scan, and every way a scan can fail leaves all LEDs
// off, says what failed and leaves no scan directory behind.

#include <chrono>
#include <cstdint>
#include <fstream>
#include <functional>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "psrig/config/config_loader.h"
#include "psrig/formats/image_io.h"
#include "psrig/formats/scan_layout.h"
#include "psrig/formats/scan_reader.h"
#include "psrig/processing/pipeline.h"
#include "psrig/rig/rig.h"
#include "psrig/rig/scan_sequencer.h"
#include "psrig/rig/storage_settings.h"
#include "psrig/sim/sim_lights.h"
#include "psrig/sim/world.h"
#include "test_support.h"

namespace psrig::rig {
namespace {

using namespace std::chrono;
using namespace std::chrono_literals;
using lights::SafeLights;

// config/sim.toml, at a size a unit test can afford.
config::RigConfig small_sim_config() {
  auto config = config::load_config(std::filesystem::path(PSRIG_SOURCE_DIR) / "config/sim.toml");
  EXPECT_TRUE(config.has_value()) << (config ? "" : config.error().describe());
  config->sim.width = 256;
  config->sim.height = 192;
  return *config;
}

void expect_all_off_and_never_two_on(const SafeLights& lights) {
  EXPECT_FALSE(lights.log().overlap()) << *lights.log().overlap();
  EXPECT_TRUE(lights.log().on_now().empty());
  EXPECT_FALSE(lights.lit());
}

TEST(ScanSequencer, SimulatedScanRecoversTheSwatchNormals) {
  test::TempDir dir;
  const auto config = small_sim_config();
  auto rig = open_rig(config);
  ASSERT_TRUE(rig) << rig.error().describe();
  ScanSequencer sequencer(config, *rig->lights, *rig->camera);
  auto request = rig->request(config);
  request.directory = dir / "scan";
  request.sample_id = "J-0001";
  std::vector<std::string> steps;
  auto outcome =
      sequencer.capture(request, [&](const ScanProgress& p) { steps.push_back(p.step); });
  ASSERT_TRUE(outcome) << outcome.error().describe();

  ASSERT_TRUE(outcome->maps);
  const auto& report = outcome->maps->report;
  ASSERT_TRUE(report["ground_truth"].contains("angular_error_deg")) << report.dump(2);
  EXPECT_LE(report["ground_truth"]["angular_error_deg"]["mean"].get<double>(), 1.0);
  EXPECT_GT(report["pixels"]["valid"].get<double>() / report["pixels"]["total"].get<double>(), 0.6);
  EXPECT_EQ(steps, (std::vector<std::string>{"dark frame", "light 1 of 3", "light 2 of 3",
                                             "light 3 of 3", "writing", "processing"}));
  // Both sides of the switch agree: never two on, all off at the end.
  expect_all_off_and_never_two_on(*rig->lights);
  EXPECT_FALSE(rig->world->leds()->log().overlap());
  EXPECT_TRUE(rig->world->leds()->leds_on().empty());

  // The scan directory reads back with its capture record.
  auto scan = formats::read_scan(request.directory);
  ASSERT_TRUE(scan) << scan.error().describe();
  EXPECT_EQ(scan->frames.size(), 3U);
  EXPECT_FALSE(scan->dark.empty());
  EXPECT_EQ(scan->description.sample_id, "J-0001");
  EXPECT_EQ(scan->description.document["capture"]["frames_averaged"], 2);
}

// A free-running camera whose frames say what lit them: 1000 × (channel +
// 1) when one LED was on for the whole exposure, 64 when all were off, and
// kMixed when the lighting changed during it. It reads the lighting from
// the light controller's switch log, so it sees what the LEDs did, not what
// the sequencer meant them to do.
class ScriptedCamera final : public cameras::Camera {
 public:
  static constexpr double kMixed = 4000;

  explicit ScriptedCamera(const SafeLights& lights) : lights_(lights) {}

  lights::Clock::duration period = 10ms;
  lights::Clock::duration exposure = 6ms;
  std::function<lights::Clock::duration(int frame)> jitter;  // shifts a frame's exposure
  int frames_before_silence = -1;                    // then every grab times out
  std::function<void(int grabbed)> on_grab;
  int stops = 0;

  Status configure(const config::CameraConfig&) override { return {}; }
  Status start() override {
    t0_ = lights::Clock::now();
    next_ = 0;
    return {};
  }
  Status stop() override {
    ++stops;
    return {};
  }
  std::string describe() const override { return "scripted camera"; }

  Result<cameras::Frame> grab(milliseconds timeout) override {
    const int n = next_++;
    if (on_grab) on_grab(n + 1);
    if (frames_before_silence >= 0 && n >= frames_before_silence)
      return std::unexpected(io_error(
          "scripted camera", "no frame within " + std::to_string(timeout.count()) + " ms"));
    cameras::Frame frame;
    frame.exposure_start = t0_ + n * period + (jitter ? jitter(n) : lights::Clock::duration{});
    frame.exposure_end = frame.exposure_start + exposure;
    std::this_thread::sleep_until(t0_ + (n + 1) * period);  // read out
    frame.sequence = static_cast<std::uint64_t>(n);
    frame.white_level = 4095;
    frame.exposure_us = static_cast<int>(duration_cast<microseconds>(exposure).count());
    frame.image = cv::Mat(8, 8, CV_16UC1, cv::Scalar(lighting_value(frame)));
    return frame;
  }

 private:
  // The LED lit at each switch, replayed over the exposure.
  double lighting_value(const cameras::Frame& frame) const {
    int state = -1;
    bool changed_during = false;
    for (const auto& event : lights_.log().events()) {
      const int after =
          event.on ? event.channel : (event.channel == state || event.channel < 0 ? -1 : state);
      if (event.time > frame.exposure_end) break;
      if (event.time >= frame.exposure_start && after != state) changed_during = true;
      state = after;
    }
    if (changed_during) return kMixed;
    return state < 0 ? 64 : 1000.0 * (state + 1);
  }

  const SafeLights& lights_;
  lights::Clock::time_point t0_;
  int next_ = 0;
};

struct ScriptedRig {
  config::RigConfig config = [] {
    config::RigConfig c;
    c.capture.dark_frame = true;
    c.capture.settle_ms = 1;
    c.capture.process = false;
    c.camera.frames_average = 2;
    c.camera.frames_discard = 0;
    c.camera.timeout_ms = 50;
    return c;
  }();
  SafeLights lights{sim::open_sim_lights(config).value(), 5s};
  ScriptedCamera camera{lights};
  ScanSequencer sequencer{config, lights, camera};
};

// Every stored frame holds only frames lit wholly by its own LED (or by none).
void expect_pure_frames(const formats::Scan& scan) {
  const double scale = std::floor(65535.0 / 4095);
  const auto expect_value = [&](const cv::Mat& frame, double value, const std::string& what) {
    double lo = 0, hi = 0;
    cv::minMaxLoc(frame, &lo, &hi);
    EXPECT_EQ(lo, value * scale) << what;
    EXPECT_EQ(hi, value * scale) << what;
  };
  expect_value(scan.dark, 64, "dark frame");
  ASSERT_EQ(scan.frames.size(), 3U);
  for (int k = 0; k < 3; ++k)
    expect_value(scan.frames[k], 1000.0 * (k + 1), "LED " + std::to_string(k));
}

// Bytes this process has read (read(2) and its kin, every thread, page
// cache hits included): /proc/self/io's rchar.
std::uint64_t bytes_read() {
  std::ifstream io("/proc/self/io");
  std::string key;
  std::uint64_t value = 0;
  while (io >> key >> value)
    if (key == "rchar:") return value;
  ADD_FAILURE() << "no rchar in /proc/self/io";
  return 0;
}

// The rig hands its frames to processing in memory: the scan is written
// once and never read back, and its maps are the ones processing the
// directory from the disk makes.
TEST(ScanSequencer, AScanIsProcessedFromMemoryNotReadBack) {
  test::TempDir dir;
  auto config = small_sim_config();
  config.sim.width = 480;
  config.sim.height = 360;
  auto rig = open_rig(config);
  ASSERT_TRUE(rig) << rig.error().describe();
  ScanSequencer sequencer(config, *rig->lights, *rig->camera);
  auto request = rig->request(config);
  request.directory = dir / "scan";
  const auto before = bytes_read();
  auto outcome = sequencer.capture(request, {});
  const auto captured_reads = bytes_read() - before;
  ASSERT_TRUE(outcome) << outcome.error().describe();
  ASSERT_TRUE(outcome->maps);

  std::uint64_t frame_bytes = 0;
  for (const auto& entry : std::filesystem::directory_iterator(request.directory))
    if (entry.path().extension() == ".png" && entry.path().stem() != "mask")
      frame_bytes += entry.file_size();
  ASSERT_GT(frame_bytes, 300'000U);
  EXPECT_LT(captured_reads, frame_bytes / 4)
      << captured_reads << " bytes read while scanning; the frames are " << frame_bytes;

  processing::ProcessOptions options;
  options.output = dir / "maps-from-disk";
  options.solve.reject_outliers = config.processing.reject;
  options.storage = storage_options(config.storage);
  const auto disk_before = bytes_read();
  auto from_disk = processing::process_scan(request.directory, options);
  ASSERT_TRUE(from_disk) << from_disk.error().describe();
  EXPECT_GE(bytes_read() - disk_before, frame_bytes);  // the count sees a read back
  for (const char* name : formats::map_files::kAll) {
    const auto memory = outcome->maps->maps_directory / name;
    const auto disk = options.output / name;
    ASSERT_EQ(std::filesystem::exists(memory), std::filesystem::exists(disk)) << name;
    if (!std::filesystem::exists(memory) || std::string(name).ends_with(".json")) continue;
    auto a = formats::read_image(memory, name);
    auto b = formats::read_image(disk, name);
    ASSERT_TRUE(a && b) << name;
    ASSERT_EQ(a->size(), b->size()) << name;
    EXPECT_EQ(cv::norm(*a, *b, cv::NORM_INF), 0) << name;
  }
  for (const char* section : {"pixels", "ground_truth", "inputs", "fabric"})
    EXPECT_EQ(outcome->maps->report[section], from_disk->report[section]) << section;
}

TEST(ScanSequencer, FramesExposedAcrossASwitchAreNeverUsed) {
  ScriptedRig rig;
  rig.camera.exposure = 9500us;  // no room to switch between frames
  CaptureTiming timing;
  auto scan = rig.sequencer.acquire({}, timing);
  ASSERT_TRUE(scan) << scan.error().describe();
  expect_pure_frames(*scan);
  EXPECT_EQ(timing.frames_kept, 8);
  EXPECT_GE(timing.frames_skipped, 3);  // at least one straddles each switch
  EXPECT_EQ(scan->description.document["capture"]["frames_skipped_stale"], timing.frames_skipped);
  // What `psrig scan --remote` prints from the report, as `psrig scan` from the timing.
  const auto& facts = scan->description.document["capture"];
  EXPECT_EQ(facts["frames_kept"], timing.frames_kept);
  EXPECT_EQ(facts["frames_skipped"], timing.frames_skipped);
  EXPECT_NEAR(facts["capture_ms"].get<double>(), timing.total.count(), 0.05);
  expect_all_off_and_never_two_on(rig.lights);
}

TEST(ScanSequencer, SwitchesInTheReadoutGapKeepFramesPure) {
  ScriptedRig rig;
  rig.camera.period = 20ms;
  rig.camera.exposure = 5ms;
  CaptureTiming timing;
  auto scan = rig.sequencer.acquire({}, timing);
  ASSERT_TRUE(scan) << scan.error().describe();
  expect_pure_frames(*scan);
  EXPECT_EQ(timing.frames_kept, 8);
  expect_all_off_and_never_two_on(rig.lights);
}

TEST(ScanSequencer, CameraTimingThatDriftsIsCaught) {
  ScriptedRig rig;
  // Exposures start 4 ms later than the rhythm the sequencer learnt at
  // frames 3, 5 and 7: the last each phase needs, the ones a switch in the
  // readout gap is timed after.
  rig.camera.jitter = [](int n) { return 4ms * ((n >= 3) + (n >= 5) + (n >= 7)); };
  rig.camera.period = 12ms;
  CaptureTiming timing;
  auto scan = rig.sequencer.acquire({}, timing);
  ASSERT_TRUE(scan) << scan.error().describe();
  expect_pure_frames(*scan);
  EXPECT_GE(timing.frames_skipped, 1);  // the first late frame saw both LEDs
  expect_all_off_and_never_two_on(rig.lights);
}

TEST(ScanSequencer, CameraTimeoutFailsTheScanWithAllLedsOffAndNoDirectory) {
  test::TempDir dir;
  ScriptedRig rig;
  rig.camera.frames_before_silence = 5;  // silent during the second LED
  ScanRequest request;
  request.directory = dir / "scan";
  auto outcome = rig.sequencer.capture(request);
  ASSERT_FALSE(outcome);
  EXPECT_NE(outcome.error().describe().find("no frame within 50 ms"), std::string::npos)
      << outcome.error().describe();
  EXPECT_NE(outcome.error().describe().find("scripted camera"), std::string::npos);
  expect_all_off_and_never_two_on(rig.lights);
  EXPECT_GE(rig.camera.stops, 1);
  EXPECT_TRUE(test::list_directory(dir.path()).empty());
}

TEST(ScanSequencer, StopRequestEndsTheScanWithAllLedsOff) {
  test::TempDir dir;
  ScriptedRig rig;
  rig.camera.on_grab = [&](int grabbed) {
    if (grabbed == 7) rig.sequencer.request_stop();
  };
  ScanRequest request;
  request.directory = dir / "scan";
  auto outcome = rig.sequencer.capture(request);
  ASSERT_FALSE(outcome);
  EXPECT_NE(outcome.error().describe().find("interrupted"), std::string::npos)
      << outcome.error().describe();
  expect_all_off_and_never_two_on(rig.lights);
  EXPECT_TRUE(test::list_directory(dir.path()).empty());
}

// A backend that fails to switch one channel on.
class FailingLights final : public lights::LightController {
 public:
  int channel_count() const override { return 3; }
  Status turn_on(int channel) override {
    if (channel == 1) return std::unexpected(io_error("test lights", "channel 1: line busy"));
    log_.record(channel, true);
    return {};
  }
  Status all_off() override {
    log_.record(-1, false);
    return {};
  }
  Status set_intensity(int, double) override { return {}; }
  std::string describe() const override { return "test lights"; }
};

TEST(ScanSequencer, LightFailureEndsTheScanWithAllLedsOff) {
  config::RigConfig config;
  config.capture.dark_frame = false;
  config.capture.settle_ms = 1;
  SafeLights lights(std::make_unique<FailingLights>(), 5s);
  ScriptedCamera camera(lights);
  ScanSequencer sequencer(config, lights, camera);
  CaptureTiming timing;
  auto scan = sequencer.acquire({}, timing);
  ASSERT_FALSE(scan);
  EXPECT_NE(scan.error().describe().find("channel 1: line busy"), std::string::npos)
      << scan.error().describe();
  expect_all_off_and_never_two_on(lights);
}

TEST(ScanSequencer, WatchdogCuttingAnExposureShortFailsTheScan) {
  ScriptedRig rig;
  SafeLights short_fuse(sim::open_sim_lights(rig.config).value(), 20ms);
  ScriptedCamera camera(short_fuse);
  camera.on_grab = [](int) { std::this_thread::sleep_for(15ms); };
  ScanSequencer sequencer(rig.config, short_fuse, camera);
  CaptureTiming timing;
  auto scan = sequencer.acquire({}, timing);
  ASSERT_FALSE(scan);
  EXPECT_NE(scan.error().describe().find("lights.max_on_ms"), std::string::npos)
      << scan.error().describe();
  EXPECT_TRUE(short_fuse.timed_out());
  expect_all_off_and_never_two_on(short_fuse);
}

TEST(ScanSequencer, DefaultDirectoryIsTimestampedAndSafe) {
  config::RigConfig config;
  test::TempDir dir;
  config.storage.root = dir.path();
  const auto path = default_scan_directory(config, "J 0001/../x");
  EXPECT_EQ(path.parent_path(), dir.path());
  const std::string name = path.filename().string();
  EXPECT_EQ(name.size(), std::string("20261121-170500-J_0001_.._x").size()) << name;
  EXPECT_EQ(name.substr(15), "-J_0001_.._x");
  std::filesystem::create_directory(path);
  EXPECT_NE(default_scan_directory(config, "J 0001/../x"), path);  // never reuses a name
}

}  // namespace
}  // namespace psrig::rig
