#pragma once
// The light matrix L (one unit direction per row) of Woodham's method,
// i = rho L n, and what the solve needs from it.

#include <vector>

#include <opencv2/core.hpp>

namespace psrig::processing {

struct LightMatrix {
  std::vector<cv::Vec3d> directions;              // unit rows of L
  cv::Matx33d normal_matrix;                      // L^T L
  std::vector<cv::Vec3d> pseudo_inverse_columns;  // columns of (L^T L)^-1 L^T, one per light
  double condition_number = 0;                    // largest over smallest singular value of L
};

// Normalises each direction; the condition number is infinite when L has
// rank below 3. Callers decide what to refuse (see scan_reader.h).
[[nodiscard]] LightMatrix make_light_matrix(const std::vector<cv::Vec3d>& directions);

}  // namespace psrig::processing
