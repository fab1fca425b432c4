#pragma once
// The light matrix L (one unit direction per row) of Woodham's method,
// i = rho L n, and how well it is conditioned.

#include <vector>

#include <opencv2/core.hpp>

#include "psrig/formats/scan.h"

namespace psrig::formats {

// The unit direction toward a light at `tilt_deg` (from +x toward +y) and
// `slant_deg` (from +z, the camera's axis): docs/design.md "Axes and units".
[[nodiscard]] cv::Vec3d light_direction(double tilt_deg, double slant_deg);

struct LightMatrix {
  std::vector<cv::Vec3d> directions;  // unit rows of L
  double condition_number = 0;        // largest over smallest singular value of L
};

// Normalises each direction; the condition number is infinite when L has
// rank below 3. Callers decide what to refuse (see scan_reader.h).
[[nodiscard]] LightMatrix make_light_matrix(const std::vector<cv::Vec3d>& directions);
// The matrix of a scan's lights, in their order.
[[nodiscard]] LightMatrix make_light_matrix(const ScanDescription& description);

}  // namespace psrig::formats
