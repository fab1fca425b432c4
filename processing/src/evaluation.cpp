#include "psrig/processing/evaluation.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "psrig/processing/parallel.h"

namespace psrig::processing {
namespace {

constexpr int kRowsPerChunk = 16;

// Values selected from `values`, in row-major order (so the result, and
// every statistic of it, is the same whatever the thread count).
std::vector<float> selected(const cv::Mat& values, const cv::Mat& select) {
  std::vector<float> out;
  out.reserve(values.total());
  for (int r = 0; r < values.rows; ++r) {
    const float* v = values.ptr<float>(r);
    const std::uint8_t* s = select.empty() ? nullptr : select.ptr<std::uint8_t>(r);
    for (int c = 0; c < values.cols; ++c)
      if (!s || s[c]) out.push_back(v[c]);
  }
  return out;
}

double quantile(std::vector<float>& values, double fraction) {
  const auto k = static_cast<std::size_t>(std::llround(fraction * static_cast<double>(values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

}  // namespace

Distribution describe(const cv::Mat& values, const cv::Mat& select) {
  std::vector<float> v = selected(values, select);
  Distribution d;
  d.count = v.size();
  if (v.empty()) return d;
  double sum = 0, squares = 0, largest = v.front();
  for (float x : v) {
    sum += x;
    squares += static_cast<double>(x) * x;
    largest = std::max<double>(largest, x);
  }
  d.mean = sum / static_cast<double>(v.size());
  d.rms = std::sqrt(squares / static_cast<double>(v.size()));
  d.max = largest;
  d.p95 = quantile(v, 0.95);
  d.median = quantile(v, 0.5);
  return d;
}

cv::Mat angular_error_deg(const cv::Mat& p, const cv::Mat& q, const cv::Mat& truth) {
  cv::Mat error(p.size(), CV_32F);
  parallel_chunks(p.rows, kRowsPerChunk, [&](int begin, int end) {
    for (int r = begin; r < end; ++r) {
      const float* pr = p.ptr<float>(r);
      const float* qr = q.ptr<float>(r);
      const float* t = truth.ptr<float>(r);
      float* e = error.ptr<float>(r);
      for (int c = 0; c < p.cols; ++c) {
        const double nx = -pr[c], ny = -qr[c], nz = 1;
        const double tx = t[3 * c], ty = t[3 * c + 1], tz = t[3 * c + 2];
        // atan2 of |cross| and dot stays accurate for tiny angles, unlike acos.
        const double cx = ny * tz - nz * ty, cy = nz * tx - nx * tz, cz = nx * ty - ny * tx;
        const double angle = std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), nx * tx + ny * ty + nz * tz);
        e[c] = static_cast<float>(angle * 180 / std::numbers::pi);
      }
    }
  });
  return error;
}

double mean_abs_curl(const cv::Mat& p, const cv::Mat& q, const cv::Mat& select) {
  double sum = 0;
  std::size_t count = 0;
  for (int r = 1; r + 1 < p.rows; ++r) {
    const std::uint8_t* above = select.ptr<std::uint8_t>(r - 1);
    const std::uint8_t* here = select.ptr<std::uint8_t>(r);
    const std::uint8_t* below = select.ptr<std::uint8_t>(r + 1);
    for (int c = 1; c + 1 < p.cols; ++c) {
      if (!(here[c] && above[c] && below[c] && here[c - 1] && here[c + 1])) continue;
      // y grows toward the top, i.e. toward row r - 1.
      const double dp_dy = (p.at<float>(r - 1, c) - p.at<float>(r + 1, c)) / 2;
      const double dq_dx = (q.at<float>(r, c + 1) - q.at<float>(r, c - 1)) / 2;
      sum += std::abs(dp_dy - dq_dx);
      ++count;
    }
  }
  return count ? sum / static_cast<double>(count) : 0;
}

double height_rms_error(const cv::Mat& height, const cv::Mat& truth, const cv::Mat& select) {
  cv::Mat difference = height - truth;
  std::vector<float> d = selected(difference, select);
  if (d.empty()) return 0;
  double sum = 0;
  for (float x : d) sum += x;
  const double mean = sum / static_cast<double>(d.size());
  double squares = 0;
  for (float x : d) squares += (x - mean) * (x - mean);
  return std::sqrt(squares / static_cast<double>(d.size()));
}

}  // namespace psrig::processing
