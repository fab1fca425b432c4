#pragma once
// Millimetres per pixel from a printed ChArUco board (OpenCV's aruco
// module): the board's inner chessboard corners, found through its markers
// and refined to sub-pixel, and a similarity (scale, rotation, shift)
// fitted to their known positions on the board.

#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"

namespace psrig::calibration {

struct CharucoSpec {
  int squares_x = 7;  // squares across
  int squares_y = 5;  // squares down
  double square_mm = 2.0;
  double marker_mm = 1.4;
  std::string dictionary = "DICT_4X4_50";
};

// The OpenCV predefined dictionary named (DICT_4X4_50, DICT_5X5_100, …,
// DICT_ARUCO_ORIGINAL), or -1.
[[nodiscard]] int dictionary_id(const std::string& name);

// The board as printed: `px_per_mm` pixels a millimetre, white paper (255)
// with black squares and markers (0), no margin. CV_8U.
[[nodiscard]] cv::Mat draw_charuco(const CharucoSpec& spec, double px_per_mm);

struct ScaleEstimate {
  double pixel_size_mm = 0;
  double uncertainty_mm = 0;  // one standard deviation, from the corner fit
  double rotation_deg = 0;    // the board's rotation in the image
  double fit_rms_px = 0;      // the corners' residual
  int corners = 0;            // used in the fit
  int markers = 0;            // detected
};

// From a linear grey image (any scale) of the board, flat and facing the
// camera. bad_input naming `source` when the board is not found (fewer
// than 6 corners).
[[nodiscard]] Result<ScaleEstimate> measure_scale(const cv::Mat& image, const CharucoSpec& spec,
                                                  const std::filesystem::path& source);

}  // namespace psrig::calibration
