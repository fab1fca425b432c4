#pragma once
// Decorators over the rig's camera and light backend that remember which
// of them failed, so a failed scan can be blamed on the right device (the
// PLC's error code tells a technician whether to check the camera cable or
// the LED driver).

#include <atomic>
#include <memory>

#include "psrig/cameras/camera.h"
#include "psrig/lights/light_controller.h"

namespace psrig::daemon {

struct DeviceFaults {
  std::atomic<bool> camera{false};
  std::atomic<bool> lights{false};
  void clear() {
    camera = false;
    lights = false;
  }
};

[[nodiscard]] std::unique_ptr<cameras::Camera> record_camera_faults(
    std::unique_ptr<cameras::Camera> camera, std::shared_ptr<DeviceFaults> faults);
[[nodiscard]] std::unique_ptr<lights::LightController> record_light_faults(
    std::unique_ptr<lights::LightController> lights, std::shared_ptr<DeviceFaults> faults);

}  // namespace psrig::daemon
