#include "v4l2_controls.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <linux/videodev2.h>
#include <optional>

#include <spdlog/fmt/fmt.h>

#include "psrig/base/log.h"
#include "v4l2_device.h"

namespace psrig::cameras::v4l2 {
namespace {

// A control the device offers and lets us write.
std::optional<v4l2_queryctrl> query(int fd, std::uint32_t id) {
  v4l2_queryctrl q{};
  q.id = id;
  if (xioctl(fd, VIDIOC_QUERYCTRL, &q) < 0) return std::nullopt;
  if (q.flags & (V4L2_CTRL_FLAG_DISABLED | V4L2_CTRL_FLAG_READ_ONLY)) return std::nullopt;
  return q;
}

// The nearest value the control accepts.
std::int32_t fit(const v4l2_queryctrl& q, double wanted) {
  const double step = std::max(q.step, 1);
  double v = std::clamp(wanted, static_cast<double>(q.minimum), static_cast<double>(q.maximum));
  v = q.minimum + std::round((v - q.minimum) / step) * step;
  return static_cast<std::int32_t>(std::min(v, static_cast<double>(q.maximum)));
}

// Writes `value` to a control and reads back what the device took. Errors
// name the control and the configuration key that asked for the value.
Result<std::int32_t> set_and_read(int fd, const std::string& device, const std::string& key,
                                  const char* name, const v4l2_queryctrl& q, std::int32_t value) {
  v4l2_control c{q.id, value};
  if (xioctl(fd, VIDIOC_S_CTRL, &c) < 0) {
    const int e = errno;
    if (e == EBUSY || e == ENODEV)
      return std::unexpected(ioctl_error(device, std::string("setting ") + name, e));
    return std::unexpected(bad_input(
        device, key,
        fmt::format("the camera refuses {} = {} ({}; it takes {} to {} in steps of {})", name,
                    value, errno_text(e), q.minimum, q.maximum, std::max(q.step, 1))));
  }
  c.value = 0;
  if (xioctl(fd, VIDIOC_G_CTRL, &c) < 0)
    return std::unexpected(ioctl_error(device, std::string("reading back ") + name, errno));
  return c.value;
}

// Seconds per sensor line, when the driver says (raw sensor drivers do).
std::optional<double> line_time_s(int fd, int width) {
  // HBLANK is often read-only: reading it is all we need.
  v4l2_control hblank{V4L2_CID_HBLANK, 0};
  if (xioctl(fd, VIDIOC_G_CTRL, &hblank) < 0) return std::nullopt;
  // PIXEL_RATE is a 64-bit control: only the extended API reads it.
  v4l2_ext_control rate{};
  rate.id = V4L2_CID_PIXEL_RATE;
  v4l2_ext_controls list{};
  list.which = V4L2_CTRL_WHICH_CUR_VAL;
  list.count = 1;
  list.controls = &rate;
  if (xioctl(fd, VIDIOC_G_EXT_CTRLS, &list) < 0 || rate.value64 <= 0) return std::nullopt;
  return (width + hblank.value) / static_cast<double>(rate.value64);
}

Result<int> set_exposure(int fd, const std::string& device, int exposure_us, int width) {
  const std::string key = "camera.exposure_us";
  if (query(fd, V4L2_CID_EXPOSURE_AUTO)) {
    v4l2_control manual{V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_MANUAL};
    if (xioctl(fd, VIDIOC_S_CTRL, &manual) < 0) {
      const int e = errno;
      if (e == EBUSY || e == ENODEV)
        return std::unexpected(ioctl_error(device, "setting V4L2_CID_EXPOSURE_AUTO to manual", e));
      return std::unexpected(bad_input(
          device, key,
          "the camera refuses manual exposure (V4L2_CID_EXPOSURE_AUTO = manual: " + errno_text(e) +
              "); photometric stereo needs the same exposure under every LED: use a camera "
              "with manual exposure"));
    }
  }
  if (auto q = query(fd, V4L2_CID_EXPOSURE_ABSOLUTE)) {
    auto got = set_and_read(fd, device, key, "V4L2_CID_EXPOSURE_ABSOLUTE", *q,
                            fit(*q, exposure_us / 100.0));
    if (!got) return std::unexpected(got.error());
    return *got * 100;
  }
  if (auto q = query(fd, V4L2_CID_EXPOSURE)) {
    const auto line = line_time_s(fd, width);
    if (!line)
      return std::unexpected(
          bad_input(device, key,
                    "the camera's exposure control (V4L2_CID_EXPOSURE) is in driver units and the "
                    "driver does not say its line time (V4L2_CID_PIXEL_RATE, V4L2_CID_HBLANK): use "
                    "camera.backend = \"libcamera\" for this sensor"));
    const double line_us = *line * 1e6;
    auto got =
        set_and_read(fd, device, key, "V4L2_CID_EXPOSURE", *q, fit(*q, exposure_us / line_us));
    if (!got) return std::unexpected(got.error());
    return static_cast<int>(std::lround(*got * line_us));
  }
  return std::unexpected(bad_input(
      device, key,
      "the camera has no exposure control (V4L2_CID_EXPOSURE_ABSOLUTE or V4L2_CID_EXPOSURE); "
      "photometric stereo needs a fixed, known exposure: use a camera with manual exposure"));
}

Result<double> set_gain(int fd, const std::string& device, double gain) {
  const std::string key = "camera.gain";
  if (auto q = query(fd, V4L2_CID_AUTOGAIN)) {
    v4l2_control off{V4L2_CID_AUTOGAIN, 0};
    if (xioctl(fd, VIDIOC_S_CTRL, &off) < 0)
      return std::unexpected(
          ioctl_error(device, "turning automatic gain off (V4L2_CID_AUTOGAIN)", errno));
  }
  const char* name = "V4L2_CID_ANALOGUE_GAIN";
  auto q = query(fd, V4L2_CID_ANALOGUE_GAIN);
  if (!q) {
    name = "V4L2_CID_GAIN";
    q = query(fd, V4L2_CID_GAIN);
  }
  if (!q) {
    if (std::abs(gain - 1.0) > 1e-9)
      logger("camera")->warn(
          "{}: no gain control (V4L2_CID_ANALOGUE_GAIN, V4L2_CID_GAIN): camera.gain = {} ignored",
          device, gain);
    return 1.0;
  }
  if (q->default_value <= 0) {
    // No unity to scale from: leave the driver's default.
    if (std::abs(gain - 1.0) > 1e-9)
      logger("camera")->warn(
          "{}: the gain control's default is {}, so its unity is unknown: camera.gain = {} "
          "ignored, gain left at the default",
          device, q->default_value, gain);
    auto got = set_and_read(fd, device, key, name, *q, q->default_value);
    if (!got) return std::unexpected(got.error());
    return 1.0;
  }
  const double unity = q->default_value;
  auto got = set_and_read(fd, device, key, name, *q, fit(*q, gain * unity));
  if (!got) return std::unexpected(got.error());
  return *got / unity;
}

}  // namespace

Result<ExposureAndGain> set_exposure_and_gain(int fd, const std::string& device, int exposure_us,
                                              double gain, int width) {
  auto exposure = set_exposure(fd, device, exposure_us, width);
  if (!exposure) return std::unexpected(exposure.error());
  auto actual_gain = set_gain(fd, device, gain);
  if (!actual_gain) return std::unexpected(actual_gain.error());
  auto log = logger("camera");
  if (std::abs(*exposure - exposure_us) > std::max(1.0, 0.01 * exposure_us))
    log->warn("{}: exposure {} us asked, the camera took {} us", device, exposure_us, *exposure);
  if (std::abs(*actual_gain - gain) > 0.01 * gain)
    log->warn("{}: gain {:.3f} asked, the camera took {:.3f}", device, gain, *actual_gain);
  return ExposureAndGain{*exposure, *actual_gain};
}

}  // namespace psrig::cameras::v4l2
