#pragma once
// Smooth yarn centrelines through key points. Knit loops are drawn as cubic
// splines through a few key points per loop, as in chen2003 (key points
// k0..k5 per loop joined by cardinal splines); the centripetal
// parametrisation keeps the tight loop heads free of cusps and overshoot.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "yarn_raster.h"

namespace psrig::sim::detail {

// Samples the centripetal Catmull-Rom spline through points[1 .. n-2] (the
// first and last points only steer the ends) as a polyline whose segments
// are at most `max_step_mm` long and turn by at most `max_turn_rad` (in 3D,
// so height changes count) from one to the next: straight legs get few
// vertices, tight loop heads many, and neither shows facets.
[[nodiscard]] inline std::vector<YarnVertex> sample_catmull_rom(
    const std::vector<YarnVertex>& points, double max_step_mm, double max_turn_rad) {
  std::vector<YarnVertex> fine;
  if (points.size() < 4) return fine;
  const auto lerp = [](const YarnVertex& a, const YarnVertex& b, double ta, double tb, double t) {
    const double wa = (tb - t) / (tb - ta);
    const double wb = (t - ta) / (tb - ta);
    return YarnVertex{wa * a.x + wb * b.x, wa * a.y + wb * b.y, wa * a.z + wb * b.z};
  };
  const auto distance = [](const YarnVertex& a, const YarnVertex& b) {
    return std::hypot(b.x - a.x, b.y - a.y, b.z - a.z);
  };
  const auto knot = [&](const YarnVertex& a, const YarnVertex& b) {
    return std::max(std::sqrt(distance(a, b)), 1e-6);  // centripetal: |b - a|^0.5
  };
  // Densely first, a tenth of the longest step at most.
  const double fine_step = 0.1 * max_step_mm;
  for (std::size_t i = 1; i + 2 < points.size(); ++i) {
    const YarnVertex& p0 = points[i - 1];
    const YarnVertex& p1 = points[i];
    const YarnVertex& p2 = points[i + 1];
    const YarnVertex& p3 = points[i + 2];
    const double t0 = 0;
    const double t1 = t0 + knot(p0, p1);
    const double t2 = t1 + knot(p1, p2);
    const double t3 = t2 + knot(p2, p3);
    const int steps = std::max(4, static_cast<int>(std::ceil(distance(p1, p2) / fine_step)));
    for (int k = (i == 1 ? 0 : 1); k <= steps; ++k) {
      // Barry and Goldman's pyramidal form.
      const double t = t1 + (t2 - t1) * k / steps;
      const YarnVertex a1 = lerp(p0, p1, t0, t1, t);
      const YarnVertex a2 = lerp(p1, p2, t1, t2, t);
      const YarnVertex a3 = lerp(p2, p3, t2, t3, t);
      const YarnVertex b1 = lerp(a1, a2, t0, t2, t);
      const YarnVertex b2 = lerp(a2, a3, t1, t3, t);
      fine.push_back(lerp(b1, b2, t1, t2, t));
    }
  }
  // Then keep a vertex only where the polyline would otherwise turn or stretch too far.
  std::vector<YarnVertex> out{fine.front()};
  const double cos_turn = std::cos(max_turn_rad);
  for (std::size_t k = 1; k + 1 < fine.size(); ++k) {
    const YarnVertex& last = out.back();
    const YarnVertex& next = fine[k + 1];
    const double a = distance(last, fine[k]);
    const double b = distance(fine[k], next);
    const double along = (fine[k].x - last.x) * (next.x - fine[k].x) +
                         (fine[k].y - last.y) * (next.y - fine[k].y) +
                         (fine[k].z - last.z) * (next.z - fine[k].z);
    if (distance(last, next) > max_step_mm || along < cos_turn * a * b) out.push_back(fine[k]);
  }
  out.push_back(fine.back());
  return out;
}

}  // namespace psrig::sim::detail
