#include "psrig/sim/lambertian_render.h"

#include <algorithm>
#include <cmath>

namespace psrig::sim {
namespace {

// Below this horizontal component the light counts as overhead.
constexpr double kOverhead = 1e-9;

float bilinear(const cv::Mat& height, float x, float y) {
  // x and y are within the image, so the far neighbour is clamped only at its last pixel.
  const int x0 = static_cast<int>(x);
  const int y0 = static_cast<int>(y);
  const int x1 = std::min(x0 + 1, height.cols - 1);
  const int y1 = std::min(y0 + 1, height.rows - 1);
  const float fx = x - static_cast<float>(x0);
  const float fy = y - static_cast<float>(y0);
  const auto* a = height.ptr<float>(y0);
  const auto* b = height.ptr<float>(y1);
  const float top = a[x0] + fx * (a[x1] - a[x0]);
  const float bottom = b[x0] + fx * (b[x1] - b[x0]);
  return top + fy * (bottom - top);
}

}  // namespace

cv::Mat cast_shadow_mask(const cv::Mat& height_mm, double pixel_size_mm,
                         const cv::Vec3d& direction) {
  cv::Mat mask(height_mm.size(), CV_8U, cv::Scalar(0));
  if (height_mm.empty()) return mask;
  CV_Assert(height_mm.type() == CV_32F);
  const double horizontal = std::hypot(direction[0], direction[1]);
  if (direction[2] <= 0) {
    mask.setTo(255);  // a light at or below the swatch's plane lights nothing
    return mask;
  }
  if (horizontal < kOverhead * direction[2]) return mask;
  double highest = 0;
  cv::minMaxLoc(height_mm, nullptr, &highest);

  // Half-pixel steps toward the light; y is up, so rows fall as y grows.
  constexpr float kStep = 0.5f;
  const auto dx = static_cast<float>(kStep * direction[0] / horizontal);
  const auto dy = static_cast<float>(-kStep * direction[1] / horizontal);
  const auto dz = static_cast<float>(kStep * pixel_size_mm * direction[2] / horizontal);
  const auto top = static_cast<float>(highest);
  const auto xmax = static_cast<float>(height_mm.cols - 1);
  const auto ymax = static_cast<float>(height_mm.rows - 1);

  cv::parallel_for_(cv::Range(0, height_mm.rows), [&](const cv::Range& range) {
    for (int r = range.start; r < range.end; ++r) {
      const auto* h = height_mm.ptr<float>(r);
      auto* out = mask.ptr<std::uint8_t>(r);
      for (int c = 0; c < height_mm.cols; ++c) {
        for (int k = 1;; ++k) {
          // Recomputed from the start, not accumulated, so long rays keep their aim.
          const float x = static_cast<float>(c) + static_cast<float>(k) * dx;
          const float y = static_cast<float>(r) + static_cast<float>(k) * dy;
          const float z = h[c] + static_cast<float>(k) * dz;
          if (z > top || x < 0 || y < 0 || x > xmax || y > ymax) break;
          if (bilinear(height_mm, x, y) > z) {
            out[c] = 255;
            break;
          }
        }
      }
    }
  });
  return mask;
}

cv::Mat render_lambertian(const Swatch& swatch, const DistantLight& light, bool cast_shadows) {
  cv::Mat out(swatch.normal.size(), CV_32FC3, cv::Scalar::all(0));
  const double norm = cv::norm(light.direction);
  if (swatch.normal.empty() || !(norm > 0)) return out;
  CV_Assert(swatch.normal.type() == CV_32FC3 && swatch.albedo.type() == CV_32FC3 &&
            swatch.albedo.size() == swatch.normal.size());
  const cv::Vec3f l = cv::Vec3f(light.direction / norm);
  cv::Mat shadow;
  if (cast_shadows && !swatch.height_mm.empty()) {
    shadow = cast_shadow_mask(swatch.height_mm, swatch.pixel_size_mm, light.direction);
  }
  cv::parallel_for_(cv::Range(0, out.rows), [&](const cv::Range& range) {
    for (int r = range.start; r < range.end; ++r) {
      const auto* n = swatch.normal.ptr<cv::Vec3f>(r);
      const auto* albedo = swatch.albedo.ptr<cv::Vec3f>(r);
      const auto* blocked = shadow.empty() ? nullptr : shadow.ptr<std::uint8_t>(r);
      auto* radiance = out.ptr<cv::Vec3f>(r);
      for (int c = 0; c < out.cols; ++c) {
        if (blocked != nullptr && blocked[c] != 0) continue;
        const float cosine = std::max(0.0f, n[c].dot(l));
        radiance[c] = albedo[c].mul(light.intensity_bgr) * cosine;
      }
    }
  });
  return out;
}

cv::Mat render_point_light(const Swatch& swatch, const PointLight& light, bool cast_shadows) {
  cv::Mat out(swatch.normal.size(), CV_32FC3, cv::Scalar::all(0));
  if (swatch.normal.empty()) return out;
  CV_Assert(swatch.normal.type() == CV_32FC3 && swatch.albedo.type() == CV_32FC3 &&
            swatch.albedo.size() == swatch.normal.size());
  const cv::Vec3d p = light.position_mm;
  const double p2 = p.dot(p);
  if (!(p2 > 0)) return out;
  cv::Mat shadow;
  if (cast_shadows && !swatch.height_mm.empty())
    shadow = cast_shadow_mask(swatch.height_mm, swatch.pixel_size_mm, p);
  const double mean_height = swatch.height_mm.empty() ? 0.0 : cv::mean(swatch.height_mm)[0];
  const double s = swatch.pixel_size_mm;
  const double cx = 0.5 * (out.cols - 1);
  const double cy = 0.5 * (out.rows - 1);
  cv::parallel_for_(cv::Range(0, out.rows), [&](const cv::Range& range) {
    for (int r = range.start; r < range.end; ++r) {
      const auto* n = swatch.normal.ptr<cv::Vec3f>(r);
      const auto* albedo = swatch.albedo.ptr<cv::Vec3f>(r);
      const auto* h = swatch.height_mm.empty() ? nullptr : swatch.height_mm.ptr<float>(r);
      const auto* blocked = shadow.empty() ? nullptr : shadow.ptr<std::uint8_t>(r);
      auto* radiance = out.ptr<cv::Vec3f>(r);
      const double y = (cy - r) * s;
      for (int c = 0; c < out.cols; ++c) {
        if (blocked != nullptr && blocked[c] != 0) continue;
        const double z = h != nullptr ? h[c] - mean_height : 0.0;
        const cv::Vec3d d = p - cv::Vec3d((c - cx) * s, y, z);
        const double r2 = d.dot(d);
        const double shade = std::max(0.0, cv::Vec3d(n[c]).dot(d)) * p2 / (r2 * std::sqrt(r2));
        radiance[c] = albedo[c].mul(light.intensity_bgr) * static_cast<float>(shade);
      }
    }
  });
  return out;
}

}  // namespace psrig::sim
