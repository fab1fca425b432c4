#pragma once
// The length and the 2-D cross product of image-plane vectors (lattice
// steps, repeat vectors), as the lattice code writes them.

#include <cmath>

#include <opencv2/core/types.hpp>

namespace psrig::analysis {

[[nodiscard]] inline double norm(cv::Point2d p) {
  return std::hypot(p.x, p.y);
}
[[nodiscard]] inline double cross(cv::Point2d a, cv::Point2d b) {
  return a.x * b.y - a.y * b.x;
}

}  // namespace psrig::analysis
