#pragma once
// Finding a calibration sphere in an image: a circle fitted to its
// silhouette, to a fraction of a pixel.

#include <filesystem>
#include <vector>

#include <opencv2/core.hpp>

#include "psrig/base/error.h"

namespace psrig::calibration {

// A circle in pixel coordinates: x right, y down (row), pixel centres at
// integers.
struct Circle {
  cv::Point2d centre;
  double radius = 0;
  double rms_px = 0;  // RMS distance of the edge points kept from the circle
  int points = 0;     // edge points the fit kept
};

// The sphere's silhouette: from `mask` when given (nonzero = sphere; any
// depth, grey or colour), else from the brightest value each pixel takes
// over `images` (CV_32F grey, 0..1). The largest round blob of the
// thresholded silhouette gives a first circle; then each of 720 rays from
// its centre finds where the silhouette crosses halfway between the levels
// just inside and just outside, and a circle is fitted to those points,
// dropping the points off it (3 MADs), twice.
// bad_input naming `source` (the mask, or the images' folder) when no
// round blob is there.
[[nodiscard]] Result<Circle> find_sphere(const std::vector<cv::Mat>& images, const cv::Mat& mask,
                                         const std::filesystem::path& source);

// A least-squares circle through `points` (algebraic, then geometric).
[[nodiscard]] Circle fit_circle(const std::vector<cv::Point2d>& points);

}  // namespace psrig::calibration
