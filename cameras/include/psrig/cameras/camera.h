#pragma once
// The rig's camera, behind one small interface: V4L2, libcamera and the
// simulated one, chosen by the configuration's `camera.backend`.

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/config/rig_config.h"
#include "psrig/formats/scan.h"
#include "psrig/lights/switch_log.h"

namespace psrig::cameras {

using Clock = lights::Clock;

struct Frame {
  cv::Mat image;                     // CV_8U or CV_16U, grey or BGR
  Clock::time_point exposure_start;  // on the same clock as the LED switch log
  Clock::time_point exposure_end;
  // Exposure starts of a free-running camera are this far apart, when it
  // says (zero: unknown; the sequencer then learns it from the frames).
  Clock::duration frame_interval{};
  std::uint64_t sequence = 0;  // as the camera counts them; gaps mean dropped frames
  int exposure_us = 0;         // what the camera actually used
  double gain = 0;
  double white_level = 0;  // full scale of `image` (e.g. 4095 for 12-bit data in 16 bits)
  double black_level = 0;
  // Sensor data is linear in the light; an ISP's RGB or a webcam's YUYV is
  // gamma-encoded, and the scan must say so for processing to decode it.
  formats::Encoding encoding = formats::Encoding::linear;
};

class Camera {
 public:
  virtual ~Camera() = default;

  // Applies size, format, exposure and gain; may be called only when stopped.
  [[nodiscard]] virtual Status configure(const config::CameraConfig& settings) = 0;
  [[nodiscard]] virtual Status start() = 0;
  // The next frame, waiting at most `timeout`.
  [[nodiscard]] virtual Result<Frame> grab(std::chrono::milliseconds timeout) = 0;
  [[nodiscard]] virtual Status stop() = 0;
  // "v4l2 /dev/video0 (uvcvideo, 'HD Camera'), 1920x1080 YUYV" and the like.
  [[nodiscard]] virtual std::string describe() const = 0;
  // What the camera knows of the scene beyond its frames, added to a scan it
  // took: the simulated camera writes its world's answer (the swatch's true
  // normals, heights and gauge) so that accuracy can be measured; a real
  // camera knows nothing more. No request or rig type carries it.
  virtual void describe_scene(formats::Scan& /*scan*/) const {}
};

}  // namespace psrig::cameras
