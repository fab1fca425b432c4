#pragma once
// Flat calibration targets for the simulated world: a white card filling
// the field (`[sim] target = "white_card"`), for `psrig calibrate flat`.

#include <opencv2/core.hpp>

#include "psrig/sim/swatch_model.h"

namespace psrig::sim {

// The card's reflectance: a matte white-grey card, so that under the
// simulated LEDs (led_irradiance 1.5, slant 45°) it reads ~0.8 of full
// scale at the centre of the field, unsaturated.
inline constexpr float kWhiteCardAlbedo = 0.75f;

// A flat card at height 0 facing the camera, uniform albedo, covering the
// whole field.
[[nodiscard]] Swatch white_card(cv::Size size, double pixel_size_mm);

}  // namespace psrig::sim
