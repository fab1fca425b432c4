#include "psrig/cloth/yarn_raster.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

#include <opencv2/core/utility.hpp>

namespace psrig::cloth {

namespace {

struct Segment {
  float ax, ay;  // start, mm
  float dx, dy;  // end minus start, mm
  float inv_len2, inv_len;
  float z0, dz;        // centreline height at the start, and its change
  float s0, ds;        // arc length at the start, and the segment's length
  float w, inv_w2, h;  // half-width, 1/half-width^2, half-height
  float len2_over_w2;  // (length / half-width)^2
  float lead;          // how far uphill (in t per unit section height) the top lies
  float reach;         // where the ellipse reaches max_slope
  float zmax;          // the highest the capsule gets
  int yarn;
};

inline constexpr int kBandRows = 16;

// Draws one segment into rows [row_begin, row_end) of the buffers.
void draw_segment(const Segment& s, double px, int row_begin, int row_end, YarnRaster& out) {
  const int cols = out.top.cols;
  const double ymin = std::min<double>(s.ay, s.ay + s.dy) - s.reach;
  const double ymax = std::max<double>(s.ay, s.ay + s.dy) + s.reach;
  const int r0 = std::max(row_begin, static_cast<int>(std::ceil(ymin / px - 0.5)));
  const int r1 = std::min(row_end - 1, static_cast<int>(std::floor(ymax / px - 0.5)));
  const float fpx = static_cast<float>(px);
  const float reach2 = s.reach * s.reach;
  for (int r = r0; r <= r1; ++r) {
    const float yc = (static_cast<float>(r) + 0.5f) * fpx;
    // Only the part of the segment within reach of this row matters.
    float t_lo = 0.0f;
    float t_hi = 1.0f;
    if (std::abs(s.dy) > 1e-9f) {
      const float ta = (yc - s.reach - s.ay) / s.dy;
      const float tb = (yc + s.reach - s.ay) / s.dy;
      t_lo = std::clamp(std::min(ta, tb), 0.0f, 1.0f);
      t_hi = std::clamp(std::max(ta, tb), 0.0f, 1.0f);
    }
    const float xa = s.ax + t_lo * s.dx;
    const float xb = s.ax + t_hi * s.dx;
    const int c0 =
        std::max(0, static_cast<int>(std::ceil((std::min(xa, xb) - s.reach) / fpx - 0.5f)));
    const int c1 =
        std::min(cols - 1, static_cast<int>(std::floor((std::max(xa, xb) + s.reach) / fpx - 0.5f)));
    auto* top = out.top.ptr<float>(r);
    auto* yarn = out.yarn.ptr<int>(r);
    auto* along = out.along.ptr<float>(r);
    auto* across = out.across.ptr<float>(r);
    const float ey0 = yc - s.ay;
    for (int c = c0; c <= c1; ++c) {
      if (s.zmax <= top[c]) continue;  // already covered by something higher
      const float ex0 = (static_cast<float>(c) + 0.5f) * fpx - s.ax;
      // A yarn that climbs or dives is the union of ellipsoids swept along
      // its centreline; the highest one over this pixel sits a little uphill
      // of the nearest point, by `lead` times the section's height there.
      const float u = (ex0 * s.dx + ey0 * s.dy) * s.inv_len2;
      const float q = 1.0f - (ex0 * ex0 + ey0 * ey0) * s.inv_w2 + u * u * s.len2_over_w2;
      if (q <= 0.0f) continue;
      const float t = std::clamp(u + s.lead * std::sqrt(q), 0.0f, 1.0f);
      const float ex = ex0 - t * s.dx;
      const float ey = ey0 - t * s.dy;
      const float d2 = ex * ex + ey * ey;
      if (d2 >= reach2) continue;
      const float z = s.z0 + t * s.dz + s.h * std::sqrt(1.0f - d2 * s.inv_w2);
      if (z <= top[c]) continue;
      top[c] = z;
      yarn[c] = s.yarn;
      along[c] = s.s0 + t * s.ds;
      // Signed perpendicular offset (cross product), in half-widths.
      across[c] = std::clamp((s.dx * ey - s.dy * ex) * s.inv_len / s.w, -1.0f, 1.0f);
    }
  }
}

}  // namespace

YarnRaster rasterize_yarns(std::span<const RasterYarn> yarns, cv::Size size, double px,
                           float floor_mm, double max_slope) {
  YarnRaster out;
  out.top = cv::Mat(size, CV_32F, cv::Scalar(floor_mm));
  out.yarn = cv::Mat(size, CV_32S, cv::Scalar(-1));
  out.along = cv::Mat(size, CV_32F, cv::Scalar(0));
  out.across = cv::Mat(size, CV_32F, cv::Scalar(0));

  std::vector<Segment> segments;
  for (std::size_t k = 0; k < yarns.size(); ++k) {
    const RasterYarn& yarn = yarns[k];
    const double w = yarn.half_width_mm;
    const double h = yarn.half_height_mm;
    // The ellipse z = h sqrt(1 - (d/w)^2) has slope max_slope at d = w t0.
    const double a = max_slope * w / h;
    const double t0 = a / std::sqrt(1.0 + a * a);
    double s = 0;
    for (std::size_t i = 1; i < yarn.path.size(); ++i) {
      const RasterVertex& p = yarn.path[i - 1];
      const RasterVertex& q = yarn.path[i];
      const double dx = q.x - p.x;
      const double dy = q.y - p.y;
      const double len2 = dx * dx + dy * dy;
      const double len3 = std::sqrt(len2 + (q.z - p.z) * (q.z - p.z));
      if (len2 > 1e-12) {
        Segment seg{};
        seg.ax = static_cast<float>(p.x);
        seg.ay = static_cast<float>(p.y);
        seg.dx = static_cast<float>(dx);
        seg.dy = static_cast<float>(dy);
        seg.inv_len2 = static_cast<float>(1.0 / len2);
        seg.inv_len = static_cast<float>(1.0 / std::sqrt(len2));
        seg.z0 = static_cast<float>(p.z);
        seg.dz = static_cast<float>(q.z - p.z);
        seg.s0 = static_cast<float>(s);
        seg.ds = static_cast<float>(len3);
        seg.w = static_cast<float>(w);
        seg.inv_w2 = static_cast<float>(1.0 / (w * w));
        seg.h = static_cast<float>(h);
        seg.reach = static_cast<float>(w * t0);
        seg.zmax = static_cast<float>(std::max(p.z, q.z) + h);
        // d/ds [c s + h sqrt(Q - s^2/w^2)] = 0 at s = c w^2 sqrt(Q) / sqrt(h^2 + c^2 w^2).
        const double climb = (q.z - p.z) / std::sqrt(len2);
        seg.len2_over_w2 = static_cast<float>(len2 / (w * w));
        seg.lead = static_cast<float>(climb * w * w / std::sqrt(h * h + climb * climb * w * w) /
                                      std::sqrt(len2));
        seg.yarn = static_cast<int>(k);
        segments.push_back(seg);
      }
      s += len3;
    }
  }

  // Bin segments by the bands of rows their capsules reach.
  const int bands = (size.height + kBandRows - 1) / kBandRows;
  std::vector<std::vector<int>> in_band(static_cast<std::size_t>(bands));
  for (std::size_t i = 0; i < segments.size(); ++i) {
    const Segment& seg = segments[i];
    const double ymin = std::min<double>(seg.ay, seg.ay + seg.dy) - seg.reach;
    const double ymax = std::max<double>(seg.ay, seg.ay + seg.dy) + seg.reach;
    const int r0 = std::max(0, static_cast<int>(std::floor(ymin / px - 0.5)));
    const int r1 = std::min(size.height - 1, static_cast<int>(std::ceil(ymax / px - 0.5)));
    for (int b = r0 / kBandRows; b <= r1 / kBandRows && r0 <= r1; ++b) {
      in_band[static_cast<std::size_t>(b)].push_back(static_cast<int>(i));
    }
  }

  cv::parallel_for_(cv::Range(0, bands), [&](const cv::Range& range) {
    for (int b = range.start; b < range.end; ++b) {
      const int row_begin = b * kBandRows;
      const int row_end = std::min(size.height, row_begin + kBandRows);
      // Highest first, so most of what lies beneath is rejected at a glance.
      std::vector<int>& order = in_band[static_cast<std::size_t>(b)];
      std::stable_sort(order.begin(), order.end(), [&](int i, int j) {
        return segments[static_cast<std::size_t>(i)].zmax >
               segments[static_cast<std::size_t>(j)].zmax;
      });
      for (int i : order) {
        draw_segment(segments[static_cast<std::size_t>(i)], px, row_begin, row_end, out);
      }
    }
  });
  return out;
}


std::vector<RasterYarn> raster_yarns(const YarnSet& yarns, Eigen::Vector2d origin_mm, cv::Size size,
                                     double px) {
  const double top = origin_mm.y() + size.height * px;
  std::vector<RasterYarn> out;
  out.reserve(yarns.curves.size());
  for (const YarnCurve& curve : yarns.curves) {
    RasterYarn yarn;
    yarn.half_width_mm = yarns.style.radius_mm;
    yarn.half_height_mm = yarns.style.radius_mm * yarns.style.flatness;
    yarn.path.reserve(curve.points.size());
    for (const Eigen::Vector3f& p : curve.points)
      yarn.path.push_back({p.x() - origin_mm.x(), top - p.y(), p.z()});
    out.push_back(std::move(yarn));
  }
  return out;
}

double cover_factor(const YarnSet& yarns, Eigen::Vector2d origin_mm, Eigen::Vector2d size_mm,
                    double px) {
  const cv::Size size(static_cast<int>(std::lround(size_mm.x() / px)),
                      static_cast<int>(std::lround(size_mm.y() / px)));
  if (size.area() == 0) return 0;
  // Every yarn's whole section counts: no slope cut-off.
  const YarnRaster raster =
      rasterize_yarns(raster_yarns(yarns, origin_mm, size, px), size, px, -1e9f, 1e9);
  return static_cast<double>(cv::countNonZero(raster.yarn >= 0)) / static_cast<double>(size.area());
}

}  // namespace psrig::cloth
