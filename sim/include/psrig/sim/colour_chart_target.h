#pragma once
// A ColorChecker Classic for the simulated world (`[sim] target =
// "colour_chart"`), for `psrig calibrate colour`: the 24 patches in 4 rows
// of 6, each the linear sRGB reflectance of X-Rite's published L*a*b*
// (calibration/colour.h, the one table), on the chart's black frame, lying
// on a grey card. Scaled to the field (the real chart is 279 x 216 mm, the
// simulated field ~16 x 12 mm) and turned a little, as a chart laid by hand.

#include <opencv2/core.hpp>

#include "psrig/sim/swatch_model.h"

namespace psrig::sim {

inline constexpr float kChartFrameAlbedo = 0.03f;  // the chart's black frame and gaps
inline constexpr float kChartCardAlbedo = 0.35f;   // the grey card it lies on
inline constexpr double kChartTurnDeg = 3.0;       // clockwise in the image

// The chart centred in the field, its width 85 % of the field's (or its
// height 85 %, whichever is smaller), drawn at 4 samples a pixel a side
// and averaged into the sensor's pixels. Flat, facing the camera.
[[nodiscard]] Swatch colour_chart(cv::Size size, double pixel_size_mm);

}  // namespace psrig::sim
