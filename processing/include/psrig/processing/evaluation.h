#pragma once
// Summary statistics for the report: pixel counts, residuals, integrability,
// and errors against the ground truth that simulated scans carry. All are
// exact and the same whatever the thread count.

#include <cstddef>

#include <opencv2/core.hpp>

namespace psrig::processing {

struct Distribution {
  std::size_t count = 0;
  double mean = 0;
  double median = 0;
  double p95 = 0;
  double max = 0;
  double rms = 0;
};

// Of the finite CV_32F values where `select` (CV_8U) is nonzero; all when empty.
[[nodiscard]] Distribution describe(const cv::Mat& values, const cv::Mat& select = {});
// The same but for the quantiles (median and p95 stay 0): one pass.
[[nodiscard]] Distribution describe_moments(const cv::Mat& values, const cv::Mat& select = {});

// How many pixels carry each of the solve's flags (see woodham.h).
struct PixelCounts {
  std::size_t total = 0, valid = 0, outside_mask = 0, saturated = 0, shadowed = 0, low_signal = 0,
              no_solution = 0, recovered = 0, highlight = 0;
};
[[nodiscard]] PixelCounts count_pixels(const cv::Mat& flags);

// Per-pixel angle in degrees between the normals of (p, q) and `truth`
// (CV_32FC3, x y z), CV_32F.
[[nodiscard]] cv::Mat angular_error_deg(const cv::Mat& p, const cv::Mat& q, const cv::Mat& truth);

// Mean |dp/dy - dq/dx| (central differences) over pixels whose four
// neighbours are selected too. Zero for an integrable field; wrong light
// directions or ambient light raise it, so it checks a real scan without
// ground truth.
[[nodiscard]] double mean_abs_curl(const cv::Mat& p, const cv::Mat& q, const cv::Mat& select);

// RMS of height - truth over `select` once their mean difference there is
// removed (integration fixes heights only up to a constant).
[[nodiscard]] double height_rms_error(const cv::Mat& height, const cv::Mat& truth,
                                      const cv::Mat& select = {});

}  // namespace psrig::processing
