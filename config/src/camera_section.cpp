// rig.toml's [camera].

#include <array>
#include <vector>

#include "section_readers.h"
#include "toml_section.h"

namespace psrig::config {

Status read_camera(Section& camera, RigConfig& c) {
  auto& cam = c.camera;
  PSRIG_TRY(camera.get("backend", cam.backend, {"v4l2", "libcamera", "sim"}));
  PSRIG_TRY(camera.get("device", cam.device));
  PSRIG_TRY(camera.get("format", cam.format));
  PSRIG_TRY(camera.get("width", cam.width, 0, 65535));
  PSRIG_TRY(camera.get("height", cam.height, 0, 65535));
  PSRIG_TRY(camera.get("exposure_us", cam.exposure_us, 1, 60000000));
  PSRIG_TRY(camera.get("gain", cam.gain, 0, 1000, true));
  PSRIG_TRY(camera.get("frames_average", cam.frames_average, 1, 64));
  PSRIG_TRY(camera.get("frames_discard", cam.frames_discard, 0, 64));
  PSRIG_TRY(camera.get("timeout_ms", cam.timeout_ms, 1, 600000));
  {
    std::vector<double> point;
    PSRIG_TRY(camera.get("principal_point_px", point, 0, 65535));
    if (camera.find("principal_point_px")) {
      if (point.size() != 2)
        return std::unexpected(camera.error_at(
            camera.find("principal_point_px"), "principal_point_px",
            "expected [x, y] in pixels (where the camera axis meets the image, from the "
            "top-left corner); leave it out for the image centre"));
      cam.principal_point_px = std::array<double, 2>{point[0], point[1]};
    }
  }
  camera.finish();
  return {};
}

}  // namespace psrig::config
