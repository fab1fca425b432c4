#include "psrig/processing/flatten.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <numbers>
#include <string>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

namespace psrig::processing {
namespace {

// Quadratic a + b x + c y + d x^2 + e x y + f y^2 in coordinates scaled to
// about [-1, 1], fitted in double over a grid of samples (every pixel up to
// a million samples, then a regular subset).
cv::Mat fit_quadratic(const cv::Mat& height, const cv::Mat& valid) {
  const int w = height.cols;
  const int h = height.rows;
  const double cx = 0.5 * (w - 1);
  const double cy = 0.5 * (h - 1);
  const double scale = 1.0 / std::max(1.0, 0.5 * std::max(w, h));
  const int step = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(w) * h / 1e6)));
  Eigen::Matrix<double, 6, 6> normal = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> rhs = Eigen::Matrix<double, 6, 1>::Zero();
  const auto basis = [&](int row, int col) {
    const double x = (col - cx) * scale;
    const double y = (cy - row) * scale;
    Eigen::Matrix<double, 6, 1> v;
    v << 1.0, x, y, x * x, x * y, y * y;
    return v;
  };
  for (int row = 0; row < h; row += step)
    for (int col = 0; col < w; col += step) {
      if (valid.at<std::uint8_t>(row, col) == 0) continue;
      const auto v = basis(row, col);
      normal += v * v.transpose();
      rhs += v * static_cast<double>(height.at<float>(row, col));
    }
  // Too few samples for all six terms: the pseudo-inverse keeps what it can.
  const Eigen::Matrix<double, 6, 1> coefficients =
      normal.completeOrthogonalDecomposition().solve(rhs);
  cv::Mat surface(h, w, CV_32F);
  for (int row = 0; row < h; ++row) {
    auto* out = surface.ptr<float>(row);
    for (int col = 0; col < w; ++col)
      out[col] = static_cast<float>(basis(row, col).dot(coefficients));
  }
  return surface;
}

// Gaussian low-pass of `values` weighted by `weight` (normalised
// convolution), computed on a grid coarse enough that sigma spans about
// four of its cells, then interpolated back.
cv::Mat normalised_low_pass(const cv::Mat& values, const cv::Mat& weight, double sigma) {
  const double factor = std::max(1.0, std::floor(sigma / 4.0));
  const cv::Size small(std::max(1, static_cast<int>(std::lround(values.cols / factor))),
                       std::max(1, static_cast<int>(std::lround(values.rows / factor))));
  cv::Mat weighted;
  cv::multiply(values, weight, weighted);
  cv::Mat v_small;
  cv::Mat w_small;
  cv::resize(weighted, v_small, small, 0, 0, cv::INTER_AREA);
  cv::resize(weight, w_small, small, 0, 0, cv::INTER_AREA);
  const double s = sigma * small.width / values.cols;
  cv::GaussianBlur(v_small, v_small, cv::Size(), s, s, cv::BORDER_CONSTANT);
  cv::GaussianBlur(w_small, w_small, cv::Size(), s, s, cv::BORDER_CONSTANT);
  cv::Mat ratio(small, CV_32F);
  for (int row = 0; row < small.height; ++row)
    for (int col = 0; col < small.width; ++col) {
      const float wv = w_small.at<float>(row, col);
      ratio.at<float>(row, col) = wv > 1e-6F ? v_small.at<float>(row, col) / wv : 0.0F;
    }
  cv::Mat low;
  cv::resize(ratio, low, values.size(), 0, 0, cv::INTER_LINEAR);
  return low;
}

}  // namespace

Result<BendRemoved> remove_bend(cv::Mat& height, double cutoff_px) {
  try {
    if (height.empty() || height.type() != CV_32FC1)
      return std::unexpected(
          bad_input({}, {}, "flatten: the height must be a one-channel float image"));
    if (!(cutoff_px > 0) || !std::isfinite(cutoff_px))
      return std::unexpected(bad_input({}, {}, "flatten: the cut-off must be positive"));
    // Finite heights only.
    cv::Mat valid = height == height;  // NaN compares unequal
    valid &= cv::abs(height) <= std::numeric_limits<float>::max();
    BendRemoved result;
    result.bend =
        cv::Mat(height.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
    if (cv::countNonZero(valid) == 0) return result;

    cv::Mat clean = height.clone();
    clean.setTo(0.0F, valid == 0);
    const cv::Mat quadratic = fit_quadratic(clean, valid);
    cv::Mat weight;
    valid.convertTo(weight, CV_32F, 1.0 / 255.0);
    const cv::Mat remainder = (clean - quadratic).mul(weight);
    const double sigma = cutoff_px * std::sqrt(std::numbers::ln2 / 2.0) / std::numbers::pi;
    const cv::Mat bend = quadratic + normalised_low_pass(remainder, weight, sigma);

    bend.copyTo(result.bend, valid);
    cv::subtract(height, bend, height, valid);
    double low = 0;
    double high = 0;
    cv::minMaxLoc(bend, &low, &high, nullptr, nullptr, valid);
    result.peak_to_valley = high - low;
    cv::Scalar mean;
    cv::Scalar deviation;
    cv::meanStdDev(bend, mean, deviation, valid);
    result.rms = deviation[0];
    return result;
  } catch (const std::exception& e) {
    return std::unexpected(internal_error(std::string("flatten: ") + e.what()));
  }
}

}  // namespace psrig::processing
