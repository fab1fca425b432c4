#include "psrig/cloth/yarn_spline.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "catmull_rom.h"

namespace psrig::cloth {

void sample_yarn(std::span<const YarnControlPoint> control, int samples_per_span, bool coloured,
                 YarnCurve& curve) {
  const int per_span = std::max(samples_per_span, 1);
  const std::size_t spans = control.empty() ? 0 : control.size() - 1;
  const std::size_t samples = control.empty() ? 0 : spans * static_cast<std::size_t>(per_span) + 1;
  curve.points.resize(samples);
  curve.normals.resize(samples);
  curve.lift.resize(samples);
  curve.colours.resize(coloured ? samples : 0);
  const float step = 1.0f / static_cast<float>(per_span);
  std::vector<Eigen::Vector4f> weights(static_cast<std::size_t>(per_span));
  for (int j = 0; j < per_span; ++j)
    weights[static_cast<std::size_t>(j)] = catmull_rom_weights(static_cast<float>(j) * step);
  std::size_t out = 0;
  for (std::size_t i = 0; i < spans; ++i) {
    // The ends repeat themselves as their outer neighbours.
    const YarnControlPoint& p0 = control[i == 0 ? 0 : i - 1];
    const YarnControlPoint& p1 = control[i];
    const YarnControlPoint& p2 = control[i + 1];
    const YarnControlPoint& p3 = control[std::min(i + 2, spans)];
    // The span's first sample is its control point; the cloth's normal only
    // needs blending (and renormalising) where the two ends' normals differ,
    // which on a flat cloth they never do.
    const bool same_normal = p1.normal == p2.normal;
    curve.points[out] = p1.position;
    curve.normals[out] = p1.normal;
    curve.lift[out] = p1.lift;
    if (coloured) curve.colours[out] = p1.colour;
    ++out;
    for (int j = 1; j < per_span; ++j, ++out) {
      const Eigen::Vector4f& w = weights[static_cast<std::size_t>(j)];
      const float t = static_cast<float>(j) * step;
      curve.points[out] =
          w.x() * p0.position + w.y() * p1.position + w.z() * p2.position + w.w() * p3.position;
      if (same_normal) {
        curve.normals[out] = p1.normal;
      } else {
        const Eigen::Vector3f normal = (1 - t) * p1.normal + t * p2.normal;
        curve.normals[out] = normal * (1 / std::sqrt(std::max(normal.squaredNorm(), 1e-12f)));
      }
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

}  // namespace psrig::cloth
