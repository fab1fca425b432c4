#pragma once
// The libcamera camera backend: a camera through libcamera 0.0.3 (camera.backend = "libcamera").

#include <memory>
#include <string>
#include <vector>

#include "psrig/capture/camera.h"

namespace psrig::capture {

// Starts a camera manager and acquires camera.device (an id; empty: the first).
[[nodiscard]] Result<std::unique_ptr<Camera>> open_libcamera_camera(
    const config::CameraConfig& config);

// "id (model)" of every camera libcamera finds, for `psrig devices`.
[[nodiscard]] Result<std::vector<std::string>> list_libcamera_cameras();

}  // namespace psrig::capture
