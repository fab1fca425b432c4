#include "psrig/capture/rig.h"

#include <chrono>

namespace psrig::capture {

Result<Rig> open_rig(const config::RigConfig& config, bool with_camera,
                     const RigWrappers& wrappers) {
  Rig rig;
  if (with_camera && config.camera.backend == "sim") rig.world = sim::World::attach(config);
  auto backend = firmware_host::open_lights(config);
  if (!backend) return std::unexpected(std::move(backend.error()).with(ErrorCode::lights));
  if (wrappers.lights) *backend = wrappers.lights(std::move(*backend));
  rig.lights = std::make_unique<firmware_host::SafeLights>(
      std::move(*backend), std::chrono::milliseconds(config.lights.max_on_ms));
  if (with_camera) {
    auto camera = open_camera(config);
    if (!camera) return std::unexpected(std::move(camera.error()).with(ErrorCode::camera));
    rig.camera = wrappers.camera ? wrappers.camera(std::move(*camera)) : std::move(*camera);
  }
  return rig;
}

ScanRequest Rig::request(const config::RigConfig& config) const {
  ScanRequest request;
  if (world && config.camera.backend == "sim") {
    request.ground_truth_normal = world->swatch().normal;
    request.ground_truth_height = world->swatch().height_mm;
  }
  return request;
}

}  // namespace psrig::capture
