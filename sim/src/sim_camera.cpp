#include "psrig/sim/sim_camera.h"

#include <algorithm>
#include <cmath>
#include <thread>

#include "psrig/sim/scene_truth.h"
#include "psrig/sim/sensor.h"
#include "psrig/sim/world.h"

namespace psrig::sim {
namespace {

using namespace std::chrono;

// Frames the simulated driver holds for the reader; older ones are dropped
// (the sequence numbers then show the gap), as a real driver's queue does.
constexpr std::int64_t kBuffers = 4;

class SimCamera final : public cameras::Camera {
 public:
  SimCamera(const config::RigConfig& config, std::shared_ptr<World> world)
      : config_(config), world_(std::move(world)), sensor_(config.sim, config.sim.seed) {}

  Status configure(const config::CameraConfig& settings) override {
    if (running_) return std::unexpected(internal_error("sim camera: configure while streaming"));
    if (settings.format != "auto" && settings.format != "GREY" && settings.format != "BGR3")
      return std::unexpected(
          bad_input(config_.source, "camera.format",
                    "the simulated camera delivers \"BGR3\" (colour) or \"GREY\"; got \"" +
                        settings.format + "\""));
    settings_.exposure_us = settings.exposure_us;
    settings_.gain = settings.gain;
    settings_.channels = settings.format == "GREY" ? 1 : 3;
    return {};
  }

  Status start() override {
    t0_ = Clock::now();
    next_ = 0;
    running_ = true;
    return {};
  }

  Result<cameras::Frame> grab(milliseconds timeout) override {
    if (!running_) return std::unexpected(internal_error("sim camera: grab before start"));
    const auto exposure = microseconds(settings_.exposure_us);
    const auto readout = microseconds(config_.sim.readout_us);
    const auto interval = std::max(microseconds(config_.sim.frame_interval_us), exposure + readout);
    const auto now = Clock::now();
    const auto ready = [&](std::int64_t n) { return t0_ + n * interval + exposure + readout; };
    // The newest frame read out by now, if any.
    const std::int64_t newest = now < ready(0) ? -1 : (now - ready(0)) / interval;
    std::int64_t n = next_;
    if (n <= newest) {
      n = std::max(n, newest - kBuffers + 1);  // the driver dropped what did not fit its queue
    } else if (ready(n) > now + timeout) {
      std::this_thread::sleep_for(timeout);
      return std::unexpected(io_error(
          "sim camera",
          "no frame within " + std::to_string(timeout.count()) + " ms (camera.timeout_ms)"));
    } else {
      std::this_thread::sleep_until(ready(n));
    }
    next_ = n + 1;
    cameras::Frame frame;
    frame.exposure_start = t0_ + n * interval;
    frame.exposure_end = frame.exposure_start + exposure;
    frame.image =
        sensor_.expose(*world_, frame.exposure_start, settings_, static_cast<std::uint64_t>(n));
    frame.frame_interval = interval;
    frame.sequence = static_cast<std::uint64_t>(n);
    frame.exposure_us = settings_.exposure_us;
    frame.gain = settings_.gain;
    frame.white_level = sensor_.white_level();
    frame.black_level = sensor_.black_level();
    return frame;
  }

  Status stop() override {
    running_ = false;
    return {};
  }

  std::string describe() const override {
    return "simulated camera " + std::to_string(config_.sim.width) + "x" +
           std::to_string(config_.sim.height) + " " + std::to_string(config_.sim.bit_depth) +
           "-bit " + (settings_.channels == 1 ? "grey" : "colour") + ", " + config_.sim.pattern +
           " swatch";
  }

  void describe_scene(formats::Scan& scan) const override {
    add_scene_truth(*world_, config_.sim.swatch_rotation_deg, scan);
  }

 private:
  config::RigConfig config_;
  std::shared_ptr<World> world_;
  Sensor sensor_;
  SensorSettings settings_;
  Clock::time_point t0_;
  std::int64_t next_ = 0;
  bool running_ = false;
};

}  // namespace

Result<std::unique_ptr<cameras::Camera>> open_sim_camera(const config::RigConfig& config) {
  auto world = World::attach(config);
  if (!world) return std::unexpected(std::move(world.error()));
  return std::make_unique<SimCamera>(config, std::move(*world));
}

}  // namespace psrig::sim
