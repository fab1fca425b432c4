#include "psrig/rig/rig.h"

#include <chrono>
#include <optional>

#include <opencv2/imgcodecs.hpp>

#include "psrig/base/log.h"
#include "psrig/calibration/calibration_store.h"
#include "psrig/rig/open_devices.h"
#include "psrig/sim/world.h"

namespace psrig::rig {

Result<Rig> open_rig(const config::RigConfig& config, bool with_camera,
                     const RigWrappers& wrappers) {
  Rig rig;
  if (with_camera && config.camera.backend == "sim") {
    auto world = sim::World::attach(config);
    // The simulated camera's world is its device: a pattern it cannot make
    // fails the camera, as open_rig's errors say which device.
    if (!world) return std::unexpected(std::move(world.error()).with(ErrorCode::camera));
    rig.world = std::move(*world);
  }
  auto backend = open_lights(config);
  if (!backend) return std::unexpected(std::move(backend.error()).with(ErrorCode::lights));
  if (wrappers.lights) *backend = wrappers.lights(std::move(*backend));
  rig.lights = std::make_unique<lights::SafeLights>(
      std::move(*backend), std::chrono::milliseconds(config.lights.max_on_ms));
  if (with_camera) {
    auto camera = open_camera(config);
    if (!camera) return std::unexpected(std::move(camera.error()).with(ErrorCode::camera));
    rig.camera = wrappers.camera ? wrappers.camera(std::move(*camera)) : std::move(*camera);
  }
  return rig;
}

namespace {

// The rig's current light calibration (storage.root/calibrations), when it
// has one for as many lights as the configuration.
std::optional<AppliedCalibration> current_calibration(const config::RigConfig& config) {
  const calibration::CalibrationStore store(config.storage.root);
  const auto file = store.current();
  auto log = logger("capture");
  if (!file) {
    log->info(
        "no light calibration in {}: light directions from {}'s geometry "
        "(psrig calibrate lights measures them)",
        store.directory().string(), config.source.string());
    return std::nullopt;
  }
  auto stored = calibration::read_calibration(*file);
  if (!stored) {
    log->warn("the current light calibration is unusable, so rig.toml's geometry is used: {}",
              stored.error().describe());
    return std::nullopt;
  }
  if (stored->lights.size() != static_cast<std::size_t>(config.lights.channels)) {
    log->warn(
        "the current light calibration {} has {} lights but the rig {}; rig.toml's "
        "geometry is used: run psrig calibrate lights again",
        file->string(), stored->lights.size(), config.lights.channels);
    return std::nullopt;
  }
  AppliedCalibration applied;
  applied.file = *file;
  applied.created = stored->document.value("created", std::string());
  for (const auto& light : stored->lights) {
    applied.directions.push_back(light.direction);
    applied.intensities.push_back(light.intensity);
  }
  applied.pixel_size_mm = stored->pixel_size_mm;
  applied.led_positions_mm = stored->led_positions_mm;
  // The colour matrix holds for the flat field it was measured through
  // (scans divide by the flats channel by channel).
  if (stored->colour_matrix && stored->colour_flat_field != stored->flat_version)
    log->warn(
        "the colour calibration of {} was measured {}, but the current flat field is {}; scans "
        "go without colour correction: run psrig calibrate colour again",
        file->string(),
        stored->colour_flat_field.empty() ? "without a flat field"
                                          : "through flat field " + stored->colour_flat_field,
        stored->flat_version.empty() ? "none" : stored->flat_version);
  else
    applied.colour_matrix = stored->colour_matrix;
  applied.colour_version = stored->colour_version;
  for (const auto& image : stored->flat_images) {
    cv::Mat flat = cv::imread(image.string(), cv::IMREAD_UNCHANGED);
    if (flat.empty() || flat.depth() != CV_16U) {
      log->warn(
          "the flat field of {} is unusable ({} cannot be read as 16 bits), so scans go "
          "without flats: run psrig calibrate flat again",
          file->string(), image.string());
      applied.flats.clear();
      break;
    }
    applied.flats.push_back(flat);
  }
  return applied;
}

}  // namespace

ScanRequest Rig::request(const config::RigConfig& config) const {
  ScanRequest request;
  request.calibration = current_calibration(config);
  return request;
}

}  // namespace psrig::rig
