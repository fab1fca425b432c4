#pragma once
// Flat calibration targets for the simulated world: a white card filling
// the field (`[sim] target = "white_card"`), for `psrig calibrate flat`,
// and a printed ChArUco board (`"charuco_board"`), for `psrig calibrate
// scale`.

#include <opencv2/core.hpp>

#include "psrig/sim/swatch_model.h"

namespace psrig::sim {

// The card's reflectance: a matte white-grey card, so that under the
// simulated LEDs (led_irradiance 1.5, slant 45°) it reads ~0.8 of full
// scale at the centre of the field, unsaturated.
inline constexpr float kWhiteCardAlbedo = 0.75f;

// A flat card at height 0 facing the camera, uniform albedo, covering the
// whole field.
[[nodiscard]] Swatch white_card(cv::Size size, double pixel_size_mm,
                                float albedo = kWhiteCardAlbedo);

// The simulated ChArUco board (psrig calibrate scale's defaults): 7 x 5
// squares of 2 mm, markers 1.4 mm, DICT_4X4_50, printed on the white card
// (black ink kBoardInkAlbedo), centred in the field.
inline constexpr int kBoardSquaresX = 7;
inline constexpr int kBoardSquaresY = 5;
inline constexpr double kBoardSquareMm = 2.0;
inline constexpr double kBoardMarkerMm = 1.4;
inline constexpr float kBoardInkAlbedo = 0.04f;

// The board drawn by OpenCV's aruco module at 4 samples a pixel a side and
// averaged into the sensor's pixels.
[[nodiscard]] Swatch charuco_board(cv::Size size, double pixel_size_mm);

}  // namespace psrig::sim
