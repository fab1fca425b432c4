#include "psrig/preview/yarn_spline.h"

#include <algorithm>

namespace psrig::preview {
namespace {

Eigen::Vector3f catmull_rom(const Eigen::Vector3f& p0, const Eigen::Vector3f& p1,
                            const Eigen::Vector3f& p2, const Eigen::Vector3f& p3, float t) {
  const float t2 = t * t, t3 = t2 * t;
  return 0.5f * ((2 * p1) + (p2 - p0) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t2 +
                 (3 * p1 - p0 - 3 * p2 + p3) * t3);
}

}  // namespace

void sample_yarn(std::span<const YarnControlPoint> control, int samples_per_span, bool coloured,
                 YarnCurve& curve) {
  const int per_span = std::max(samples_per_span, 1);
  const std::size_t spans = control.empty() ? 0 : control.size() - 1;
  const std::size_t samples = control.empty() ? 0 : spans * static_cast<std::size_t>(per_span) + 1;
  curve.points.resize(samples);
  curve.normals.resize(samples);
  curve.lift.resize(samples);
  curve.colours.resize(coloured ? samples : 0);
  std::size_t out = 0;
  for (std::size_t i = 0; i < spans; ++i) {
    // The ends repeat themselves as their outer neighbours.
    const YarnControlPoint& p0 = control[i == 0 ? 0 : i - 1];
    const YarnControlPoint& p1 = control[i];
    const YarnControlPoint& p2 = control[i + 1];
    const YarnControlPoint& p3 = control[std::min(i + 2, spans)];
    for (int j = 0; j < per_span; ++j, ++out) {
      const float t = static_cast<float>(j) / static_cast<float>(per_span);
      curve.points[out] = catmull_rom(p0.position, p1.position, p2.position, p3.position, t);
      curve.normals[out] = ((1 - t) * p1.normal + t * p2.normal).normalized();
      curve.lift[out] = (1 - t) * p1.lift + t * p2.lift;
      if (coloured) curve.colours[out] = (1 - t) * p1.colour + t * p2.colour;
    }
  }
  if (samples == 0) return;
  const YarnControlPoint& last = control.back();
  curve.points[out] = last.position;
  curve.normals[out] = last.normal;
  curve.lift[out] = last.lift;
  if (coloured) curve.colours[out] = last.colour;
}

}  // namespace psrig::preview
