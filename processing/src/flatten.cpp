#include "psrig/processing/flatten.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <exception>
#include <limits>
#include <numbers>
#include <string>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "psrig/base/parallel.h"
#include "psrig/base/vector_clones.h"

namespace psrig::processing {
namespace {

constexpr int kFlattenRowsPerChunk = 16;

// A row of c0 + c1 x + c2 y + c3 x^2 + c4 xy + c5 y^2, x = (col - cx) scale,
// as floats: the sum in the order Eigen's dot of the basis (1, x, y, x^2,
// xy, y^2) with c makes it in two-lane packets, (c0 + (y c2 + xy c4)) +
// (x c1 + (x^2 c3 + y^2 c5)), so the values are those of the dot to the bit
// (checked over ten million random pixels, and the 12 MP maps byte for
// byte), in a loop that vectorises.
PSRIG_VECTOR_CLONES
void quadratic_row(const double* __restrict c, double cx, double y, double scale,
                   float* __restrict out, int w) {
  const double y2 = y * y;
  for (int col = 0; col < w; ++col) {
    const double x = (col - cx) * scale;
    const double sum =
        (1.0 * c[0] + (y * c[2] + (x * y) * c[4])) + (x * c[1] + ((x * x) * c[3] + y2 * c[5]));
    out[col] = static_cast<float>(sum);
  }
}

// Quadratic a + b x + c y + d x^2 + e x y + f y^2 in coordinates scaled to
// about [-1, 1], fitted in double over a grid of samples (every pixel up to
// a million samples, then a regular subset) of the valid pixels.
class Quadratic {
 public:
  Quadratic(const cv::Mat& height, const cv::Mat& valid)
      : cx_(0.5 * (height.cols - 1)),
        cy_(0.5 * (height.rows - 1)),
        scale_(1.0 / std::max(1.0, 0.5 * std::max(height.cols, height.rows))) {
    const int w = height.cols;
    const int h = height.rows;
    const int step = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(w) * h / 1e6)));
    Eigen::Matrix<double, 6, 6> normal = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> rhs = Eigen::Matrix<double, 6, 1>::Zero();
    for (int row = 0; row < h; row += step)
      for (int col = 0; col < w; col += step) {
        if (valid.at<std::uint8_t>(row, col) == 0) continue;
        const auto v = basis(row, col);
        normal += v * v.transpose();
        rhs += v * static_cast<double>(height.at<float>(row, col));
      }
    // Too few samples for all six terms: the pseudo-inverse keeps what it can.
    coefficients_ = normal.completeOrthogonalDecomposition().solve(rhs);
  }

  // Its values along a row: the floats of basis(row, col).dot(c), the
  // surface the fit is of, 20 times faster than that expression.
  void row(int row, float* out, int w) const {
    quadratic_row(coefficients_.data(), cx_, (cy_ - row) * scale_, scale_, out, w);
  }

 private:
  [[nodiscard]] Eigen::Matrix<double, 6, 1> basis(int row, int col) const {
    const double x = (col - cx_) * scale_;
    const double y = (cy_ - row) * scale_;
    Eigen::Matrix<double, 6, 1> v;
    v << 1.0, x, y, x * x, x * y, y * y;
    return v;
  }

  double cx_;
  double cy_;
  double scale_;
  Eigen::Matrix<double, 6, 1> coefficients_;
};

// Gaussian low-pass of `weighted` (values already multiplied by `weight`)
// weighted by `weight` (normalised convolution), computed on a grid coarse
// enough that sigma spans about four of its cells, then interpolated back.
// Both inputs are released once the coarse grid has them.
cv::Mat normalised_low_pass(cv::Mat weighted, cv::Mat weight, double sigma) {
  const cv::Size size = weighted.size();
  const double factor = std::max(1.0, std::floor(sigma / 4.0));
  const cv::Size small(std::max(1, static_cast<int>(std::lround(size.width / factor))),
                       std::max(1, static_cast<int>(std::lround(size.height / factor))));
  cv::Mat v_small;
  cv::Mat w_small;
  cv::resize(weighted, v_small, small, 0, 0, cv::INTER_AREA);
  weighted.release();
  cv::resize(weight, w_small, small, 0, 0, cv::INTER_AREA);
  weight.release();
  const double s = sigma * small.width / size.width;
  cv::GaussianBlur(v_small, v_small, cv::Size(), s, s, cv::BORDER_CONSTANT);
  cv::GaussianBlur(w_small, w_small, cv::Size(), s, s, cv::BORDER_CONSTANT);
  cv::Mat ratio(small, CV_32F);
  for (int row = 0; row < small.height; ++row)
    for (int col = 0; col < small.width; ++col) {
      const float wv = w_small.at<float>(row, col);
      ratio.at<float>(row, col) = wv > 1e-6F ? v_small.at<float>(row, col) / wv : 0.0F;
    }
  cv::Mat low;
  cv::resize(ratio, low, size, 0, 0, cv::INTER_LINEAR);
  return low;
}

}  // namespace

// The whole computation on the pool, with no more planes than it needs (at
// 12 MP three 48 MB planes less than the plain expression of it): the same
// values.
Result<BendRemoved> remove_bend(cv::Mat& height, double cutoff_px, bool keep_bend) {
  try {
    if (height.empty() || height.type() != CV_32FC1)
      return std::unexpected(
          bad_input({}, {}, "flatten: the height must be a one-channel float image"));
    if (!(cutoff_px > 0) || !std::isfinite(cutoff_px))
      return std::unexpected(bad_input({}, {}, "flatten: the cut-off must be positive"));
    const int w = height.cols;
    const int h = height.rows;
    // Finite heights only: 255 there, 0 for NaN and infinities.
    cv::Mat valid(height.size(), CV_8U);
    parallel_chunks(h, kFlattenRowsPerChunk, [&](int begin, int end) {
      for (int row = begin; row < end; ++row) {
        const float* z = height.ptr<float>(row);
        std::uint8_t* v = valid.ptr<std::uint8_t>(row);
        for (int col = 0; col < w; ++col)
          v[col] = std::abs(z[col]) <= std::numeric_limits<float>::max() ? 255 : 0;
      }
    });
    BendRemoved result;
    const auto nan_plane = [&] {
      return cv::Mat(height.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
    };
    if (keep_bend) result.bend = nan_plane();
    if (cv::countNonZero(valid) == 0) return result;

    const Quadratic quadratic(height, valid);
    // The quadratic surface, and what it leaves weighted by validity (0 or 1).
    cv::Mat surface(height.size(), CV_32F);
    cv::Mat weight(height.size(), CV_32F);
    cv::Mat remainder(height.size(), CV_32F);
    parallel_chunks(h, kFlattenRowsPerChunk, [&](int begin, int end) {
      for (int row = begin; row < end; ++row) {
        const float* z = height.ptr<float>(row);
        const std::uint8_t* v = valid.ptr<std::uint8_t>(row);
        float* sr = surface.ptr<float>(row);
        float* wr = weight.ptr<float>(row);
        float* rr = remainder.ptr<float>(row);
        quadratic.row(row, sr, w);
        for (int col = 0; col < w; ++col) {
          wr[col] = v[col] != 0 ? 1.0F : 0.0F;
          const float clean = v[col] != 0 ? z[col] : 0.0F;
          rr[col] = (clean - sr[col]) * wr[col];
        }
      }
    });
    const double sigma = cutoff_px * std::sqrt(std::numbers::ln2 / 2.0) / std::numbers::pi;
    // The bend: the quadratic plus the low-pass of the rest.
    cv::Mat bend = normalised_low_pass(std::move(remainder), std::move(weight), sigma);
    cv::add(surface, bend, bend);
    surface.release();

    if (keep_bend) bend.copyTo(result.bend, valid);
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
