#include "psrig/export/occlusion.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "psrig/base/parallel.h"

namespace psrig::export_ {

cv::Mat ambient_occlusion(const cv::Mat& height, double pixel_size, int radius_px) {
  CV_Assert(height.type() == CV_32FC1 && pixel_size > 0 && radius_px >= 1);
  cv::Mat h = height.clone();
  const cv::Mat finite = h == h;
  double low = 0;
  if (cv::countNonZero(finite) > 0) cv::minMaxLoc(h, &low, nullptr, nullptr, nullptr, finite);
  h.setTo(low, ~finite);
  // Steps along a direction: every pixel near, then growing (as HBAO's
  // jittered steps, without the jitter): ~2 log2(radius) samples.
  std::vector<int> steps;
  for (int k = 1; k <= radius_px; k = std::max(k + 1, k * 5 / 4))
    steps.push_back(k);
  constexpr int kDirections = 8;
  const double pi = std::acos(-1.0);
  // Each direction's samples as pixel offsets and their distance, once.
  struct Sample {
    int dx, dy;
    double run;  // distance in height units
  };
  std::vector<std::vector<Sample>> samples(kDirections);
  std::vector<cv::Vec2d> unit(kDirections);
  for (int d = 0; d < kDirections; ++d) {
    const double angle = 2 * pi * d / kDirections;
    unit[d] = {std::cos(angle), std::sin(angle)};
    for (int k : steps) {
      const int dx = static_cast<int>(std::lround(k * unit[d][0]));
      const int dy = static_cast<int>(std::lround(k * unit[d][1]));
      samples[d].push_back({dx, dy, std::hypot(dx, dy) * pixel_size});
    }
  }
  cv::Mat out(h.size(), CV_32F);
  psrig::parallel_chunks(h.rows, 16, [&](int begin, int end) {
    for (int r = begin; r < end; ++r) {
      const float* centre = h.ptr<float>(r);
      const float* above = h.ptr<float>(std::max(r - 1, 0));
      const float* below = h.ptr<float>(std::min(r + 1, h.rows - 1));
      const int rows_apart = std::min(r + 1, h.rows - 1) - std::max(r - 1, 0);
      float* ao = out.ptr<float>(r);
      for (int c = 0; c < h.cols; ++c) {
        // The surface's own slope (central differences): a tilted plane
        // hides nothing from itself.
        const int xl = std::max(c - 1, 0), xr = std::min(c + 1, h.cols - 1);
        const double gx = (centre[xr] - centre[xl]) / ((xr - xl) * pixel_size);
        const double gy = (below[c] - above[c]) / (rows_apart * pixel_size);
        double hidden = 0;
        for (int d = 0; d < kDirections; ++d) {
          const double tangent = gx * unit[d][0] + gy * unit[d][1];
          double best = tangent;  // the horizon's slope, never below the tangent
          for (const Sample& sample : samples[d]) {
            const int x = c + sample.dx, y = r + sample.dy;
            if (x < 0 || y < 0 || x >= h.cols || y >= h.rows) break;
            best = std::max(best, (h.ptr<float>(y)[x] - centre[c]) / sample.run);
          }
          // sin(horizon angle) - sin(tangent angle), as HBAO.
          hidden += best / std::sqrt(1 + best * best) - tangent / std::sqrt(1 + tangent * tangent);
        }
        ao[c] = static_cast<float>(1 - hidden / kDirections);
      }
    }
  });
  return out;
}

}  // namespace psrig::export_
