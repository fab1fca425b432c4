#pragma once
// Manual exposure and gain through V4L2's standard controls.
//
// Exposure: V4L2_CID_EXPOSURE_AUTO set to manual, then
// V4L2_CID_EXPOSURE_ABSOLUTE (100 us units, UVC and most bridges) or, on
// raw sensor drivers, V4L2_CID_EXPOSURE in lines, turned into time with the
// line length (width + V4L2_CID_HBLANK) over V4L2_CID_PIXEL_RATE.
// Gain: V4L2_CID_ANALOGUE_GAIN or V4L2_CID_GAIN, with V4L2_CID_AUTOGAIN off.
// V4L2 leaves gain units to the driver; we take the control's default as
// unity and the code as linear, which holds for most bridges and many
// sensors but not all (IMX219's code is 256 / (256 - gain)): such sensors
// want the libcamera backend, which knows their gain models.

#include <string>

#include "psrig/base/error.h"

namespace psrig::cameras::v4l2 {

struct ExposureAndGain {
  int exposure_us = 0;  // as read back from the device
  double gain = 1.0;
};

// Sets exposure and gain on the open device `fd` (frames `width` pixels
// wide) and reads back what the device took.
[[nodiscard]] Result<ExposureAndGain> set_exposure_and_gain(int fd, const std::string& device,
                                                            int exposure_us, double gain,
                                                            int width);

}  // namespace psrig::cameras::v4l2
