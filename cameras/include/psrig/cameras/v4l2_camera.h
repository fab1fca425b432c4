#pragma once
// The v4l2 camera backend: a V4L2 capture device, mmap streaming (camera.backend = "v4l2").

#include <memory>

#include "psrig/cameras/camera.h"

namespace psrig::cameras {

// Opens camera.device and checks it can stream; configure() picks the format.
[[nodiscard]] Result<std::unique_ptr<Camera>> open_v4l2_camera(const config::CameraConfig& config);

}  // namespace psrig::cameras
