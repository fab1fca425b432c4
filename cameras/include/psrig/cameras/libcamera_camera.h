#pragma once
// The libcamera camera backend: a camera through libcamera 0.0.3 (camera.backend = "libcamera").

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "psrig/cameras/camera.h"
#include "psrig/cameras/v4l2_formats.h"

namespace psrig::cameras {

// Starts a camera manager and acquires camera.device (an id; empty: the first).
[[nodiscard]] Result<std::unique_ptr<Camera>> open_libcamera_camera(
    const config::CameraConfig& config);

// The V4L2 format with the same memory layout as libcamera's `name`
// ("SRGGB10_CSI2P", "RGB888", "R8"...): the conversions are shared.
[[nodiscard]] std::optional<V4l2PixelFormat> v4l2_format_for_libcamera(std::string name);

// "id (model)" of every camera libcamera finds, for `psrig devices`.
[[nodiscard]] Result<std::vector<std::string>> list_libcamera_cameras();

}  // namespace psrig::cameras
