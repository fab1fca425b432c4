#include "psrig/preview/strip_points.h"

#include <algorithm>
#include <cmath>

namespace psrig::preview {

int cloth_layer(float lift_toward_eye) {
  const int layer = static_cast<int>(std::floor((lift_toward_eye + 1) / 2 * kLayers));
  return std::clamp(layer, 0, kLayers - 1);
}

namespace {

// 1 +- dither, from the piece's first point.
float piece_scale(std::size_t point, float dither) {
  std::uint32_t x = static_cast<std::uint32_t>(point) * 0x9E3779B9U;  // Weyl, then lowbias32
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return 1 + dither * (2 * static_cast<float>(x >> 8) / 16777215.0f - 1);
}

}  // namespace

void append_strip(std::span<const CentrelinePoint> points, std::size_t first, std::size_t count,
                  float px_per_mm, const PieceLimits& limits, std::vector<std::uint32_t>& indices) {
  if (count < 3) return;
  const std::size_t last = first + count - 1;
  const std::size_t start = indices.size();
  std::size_t previous = first;  // the last point drawn
  indices.push_back(static_cast<std::uint32_t>(first));
  // Draws `point`, or a neighbour of the parity the strip needs next.
  const auto draw = [&](std::size_t point) {
    if ((point & 1U) == (previous & 1U)) {
      if (point - 1 > previous)
        --point;
      else if (point < last)
        ++point;
      else
        return;  // the last two points: the strip ends one short
    }
    indices.push_back(static_cast<std::uint32_t>(point));
    previous = point;
  };
  float length = 0, turning = 0, lift_turning = 0;  // of the piece so far
  float scale = piece_scale(previous, limits.dither);
  for (std::size_t i = first + 1; i < last; ++i) {
    length += points[i - 1].length_mm * px_per_mm;
    if (i <= previous) {  // a neighbour was drawn ahead of its turn
      length = turning = lift_turning = 0;
      continue;
    }
    // Would the piece still be fine reaching on to the next point?
    const float reach = length + points[i].length_mm * px_per_mm;
    const float bend = turning + points[i].turn;
    const float lift_bend = lift_turning + points[i].lift_turn;
    const bool straight_enough =
        (reach + limits.half_width_px * bend) * bend / 8 <= scale * limits.tolerance_px;
    const bool level_enough = reach / px_per_mm * lift_bend / 4 <= scale * limits.lift_tolerance;
    const bool must = points[i].keep;
    if ((must || reach > scale * limits.max_px || !straight_enough || !level_enough) &&
        (must || length >= scale * limits.min_px)) {
      draw(i);
      length = turning = lift_turning = 0;
      scale = piece_scale(previous, limits.dither);
      continue;
    }
    turning = bend;
    lift_turning = lift_bend;
  }
  if ((last & 1U) == (previous & 1U) && last - 1 > previous) draw(last - 1);
  draw(last);
  if (indices.size() - start < 3) {
    indices.resize(start);
    return;
  }
  indices.push_back(kRestartIndex);
}

}  // namespace psrig::preview
