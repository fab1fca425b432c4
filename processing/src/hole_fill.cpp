#include "psrig/processing/hole_fill.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "psrig/base/parallel.h"

namespace psrig::processing {
namespace {

constexpr int kFillRowsPerChunk = 64;

}  // namespace

int fill_specks(cv::Mat& height, const cv::Mat& fillable, int max_area) {
  CV_Assert(height.type() == CV_32FC1 && fillable.type() == CV_8UC1 &&
            fillable.size() == height.size());
  // NaN (OpenCV's compare says NaN != NaN is false)
  cv::Mat missing(height.size(), CV_8UC1);
  parallel_chunks(height.rows, kFillRowsPerChunk, [&](int begin, int end) {
    for (int row = begin; row < end; ++row) {
      const float* h = height.ptr<float>(row);
      std::uint8_t* m = missing.ptr<std::uint8_t>(row);
      for (int col = 0; col < height.cols; ++col)
        m[col] = std::isnan(h[col]) ? 255 : 0;
    }
  });
  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(missing, labels, stats, centroids, 4, CV_32S);
  missing.release();
  if (count <= 1) return 0;
  // A component is a speck when it is small and every pixel of it fillable.
  std::vector<char> speck(static_cast<std::size_t>(count), 0);
  for (int label = 1; label < count; ++label)
    speck[label] = stats.at<int>(label, cv::CC_STAT_AREA) <= max_area;
  // Per chunk of rows: the labels with a pixel that may not be filled, and
  // then the specks' pixels, in row order (the sweeps below go in it).
  const int chunks = chunk_count(height.rows, kFillRowsPerChunk);
  std::vector<std::vector<int>> unfillable(static_cast<std::size_t>(chunks));
  parallel_chunks(height.rows, kFillRowsPerChunk, [&](int begin, int end) {
    auto& found = unfillable[static_cast<std::size_t>(begin / kFillRowsPerChunk)];
    for (int row = begin; row < end; ++row) {
      const int* l = labels.ptr<int>(row);
      const std::uint8_t* f = fillable.ptr<std::uint8_t>(row);
      for (int col = 0; col < height.cols; ++col)
        if (l[col] > 0 && f[col] == 0 && speck[l[col]]) found.push_back(l[col]);
    }
  });
  for (const auto& found : unfillable)
    for (int label : found)
      speck[label] = 0;
  std::vector<std::vector<cv::Point>> chunk_pixels(static_cast<std::size_t>(chunks));
  parallel_chunks(height.rows, kFillRowsPerChunk, [&](int begin, int end) {
    auto& found = chunk_pixels[static_cast<std::size_t>(begin / kFillRowsPerChunk)];
    for (int row = begin; row < end; ++row) {
      const int* l = labels.ptr<int>(row);
      for (int col = 0; col < height.cols; ++col)
        if (l[col] > 0 && speck[l[col]]) found.emplace_back(col, row);
    }
  });
  labels.release();
  std::vector<cv::Point> pixels;
  for (const auto& found : chunk_pixels)
    pixels.insert(pixels.end(), found.begin(), found.end());
  if (pixels.empty()) return 0;
  const auto neighbour_mean = [&](cv::Point at) {
    double sum = 0;
    int n = 0;
    for (const cv::Point step : {cv::Point(1, 0), cv::Point(-1, 0), cv::Point(0, 1), cv::Point(0, -1)}) {
      const cv::Point next = at + step;
      if (next.x < 0 || next.y < 0 || next.x >= height.cols || next.y >= height.rows) continue;
      const float value = height.at<float>(next);
      if (std::isnan(value)) continue;
      sum += value;
      ++n;
    }
    return n > 0 ? static_cast<float>(sum / n) : std::numeric_limits<float>::quiet_NaN();
  };
  // From the rim inwards (each pass reaches one pixel deeper), then
  // Gauss–Seidel sweeps toward the harmonic fill. A speck of area A is at
  // most about sqrt(A) deep; sweeps of the order of A settle it.
  for (bool any_left = true; any_left;) {
    any_left = false;
    std::vector<std::pair<cv::Point, float>> reached;
    for (const auto& at : pixels)
      if (std::isnan(height.at<float>(at))) {
        const float mean = neighbour_mean(at);
        if (std::isnan(mean)) any_left = true;
        else reached.emplace_back(at, mean);
      }
    if (reached.empty()) break;  // cannot happen: every speck touches a height
    for (const auto& [at, value] : reached) height.at<float>(at) = value;
  }
  const int sweeps = std::min(4 * max_area, 2000);
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    float change = 0;
    for (const auto& at : pixels) {
      const float value = neighbour_mean(at);
      change = std::max(change, std::abs(value - height.at<float>(at)));
      height.at<float>(at) = value;
    }
    if (change == 0) break;
  }
  return static_cast<int>(pixels.size());
}

}  // namespace psrig::processing
