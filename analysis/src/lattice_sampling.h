#pragma once
// The maps sampled on a lattice, for chart inference: a repeat folded onto
// itself (the mean over every copy in the maps), the block of whole stitch
// faces inside the maps, each face's height and mean colour. Pixels: x the
// column, y the row (down); the fabric's rows go up.

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "plane_vectors.h"
#include "psrig/analysis/chart_inference.h"

namespace psrig::analysis::inference {

// Bilinear look-up in a CV_32F map; NaN outside it or next to a NaN.
[[nodiscard]] float sample(const cv::Mat& map, cv::Point2d p);

// Zero mean, unit norm, so that a dot product is the normalised
// correlation; false (and unusable) when flat or holding NaN.
bool normalise(cv::Mat& face);

// k columns (wales) and k' rows (courses) of faces.
struct Split {
  int wales = 1, courses = 1;
};

// A repeat on the maps: `origin` its bottom-left corner, u along the
// courses, w up the wales.
struct RepeatFrame {
  cv::Point2d origin, u, w;
  [[nodiscard]] cv::Point2d at(double s, double t) const { return origin + s * u + t * w; }
  // Repeat coordinates (s, t) of a pixel.
  [[nodiscard]] cv::Point2d coordinates(cv::Point2d p) const;
};

// The repeat split into k x k' faces of n x n samples: (k' n) rows x (k n)
// columns, row 0 the repeat's top, each sample the mean over every copy of
// the repeat inside `window` (the faces as render_chart_repeat lays them).
[[nodiscard]] cv::Mat fold(const cv::Mat& height, cv::Rect window, const RepeatFrame& frame,
                           Split split, int n);

// The stitches whose faces lie wholly inside a map of `size`, the lattice
// moved to start at the bottom-left one, which is stitch `first` of the
// lattice given.
struct StitchBlock {
  StitchLattice lattice;
  int columns = 0, rows = 0;
  cv::Point first;
};
[[nodiscard]] StitchBlock inner_stitches(const StitchLattice& lattice, cv::Size size);

// Every stitch's face, n x n, row 0 its top, normalised; empty where the
// face has holes. Row-major from the bottom row.
[[nodiscard]] std::vector<cv::Mat> faces_of(const cv::Mat& height, const StitchBlock& block, int n);

// Every stitch's mean albedo (CV_32FC3 BGR or CV_32FC1), linear RGB.
[[nodiscard]] std::vector<Eigen::Vector3f> colours_of(const cv::Mat& albedo,
                                                      const StitchBlock& block, int n);

// The lattice's wale spacing (across the wales) and course spacing (across
// the course lines), pixels.
[[nodiscard]] std::pair<double, double> spacing(const StitchLattice& lattice);

}  // namespace psrig::analysis::inference
