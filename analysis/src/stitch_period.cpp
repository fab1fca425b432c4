#include "stitch_period.h"

#include <algorithm>
#include <numeric>

namespace psrig::analysis::inference {
namespace {

// Shifts within this share of the spread (best minus median) of the best
// are repeats; and within this much at least, the scatter of a mean over
// the grid's pairs of faces.
constexpr double kSpreadShare = 0.25;
constexpr double kLeast = 0.02;
// A colour repeat keeps this share of the stitches' colours.
constexpr double kColourKept = 0.95;

// Mean correlation of each face with the face dx along and dy up.
double shift_correlation(const std::vector<cv::Mat>& faces, int columns, int rows, int dx,
                         int dy) {
  double sum = 0;
  int pairs = 0;
  for (int row = 0; row + dy < rows; ++row)
    for (int column = 0; column + dx < columns; ++column) {
      const cv::Mat& a = faces[static_cast<std::size_t>(row * columns + column)];
      const cv::Mat& b = faces[static_cast<std::size_t>((row + dy) * columns + column + dx)];
      if (a.empty() || b.empty()) continue;
      sum += a.dot(b);
      ++pairs;
    }
  return pairs > 0 ? sum / pairs : -1.0;
}

// The shortest of `values` (index 0: a shift of one) close enough to the best.
int shortest_repeat(const std::vector<double>& values) {
  if (values.empty()) return 1;
  std::vector<double> sorted = values;
  std::sort(sorted.begin(), sorted.end());
  const double best = sorted.back();
  const double median = sorted[sorted.size() / 2];
  const double threshold = best - std::max(kLeast, kSpreadShare * (best - median));
  for (std::size_t i = 0; i < values.size(); ++i)
    if (values[i] >= threshold) return static_cast<int>(i) + 1;
  return 1;
}

}  // namespace

Period face_period(const std::vector<cv::Mat>& faces, int columns, int rows, int max_period) {
  std::vector<double> along, up;
  for (int dx = 1; dx <= std::min(max_period, columns / 2); ++dx)
    along.push_back(shift_correlation(faces, columns, rows, dx, 0));
  for (int dy = 1; dy <= std::min(max_period, rows / 2); ++dy)
    up.push_back(shift_correlation(faces, columns, rows, 0, dy));
  return {shortest_repeat(along), shortest_repeat(up)};
}

Period colour_period(const std::vector<std::uint8_t>& colours, int columns, int rows,
                     int max_period) {
  const auto kept = [&](int dx, int dy) {
    int same = 0, pairs = 0;
    for (int row = 0; row + dy < rows; ++row)
      for (int column = 0; column + dx < columns; ++column, ++pairs)
        same += colours[static_cast<std::size_t>(row * columns + column)] ==
                colours[static_cast<std::size_t>((row + dy) * columns + column + dx)];
    return pairs > 0 ? static_cast<double>(same) / pairs : 0.0;
  };
  Period period;
  if (colours.empty()) return period;
  for (int dx = 1; dx <= std::min(max_period, columns / 2); ++dx)
    if (kept(dx, 0) >= kColourKept) {
      period.columns = dx;
      break;
    }
  for (int dy = 1; dy <= std::min(max_period, rows / 2); ++dy)
    if (kept(0, dy) >= kColourKept) {
      period.rows = dy;
      break;
    }
  return period;
}

Period common_period(Period a, Period b) {
  return {std::lcm(a.columns, b.columns), std::lcm(a.rows, b.rows)};
}

}  // namespace psrig::analysis::inference
