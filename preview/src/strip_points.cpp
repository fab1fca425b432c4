#include "psrig/preview/strip_points.h"

#include <cmath>

namespace psrig::preview {

int cloth_layer(float lift_toward_eye) {
  return lift_toward_eye < -1.0f / 3 ? 0 : lift_toward_eye > 1.0f / 3 ? 2 : 1;
}

void choose_strip_points(std::span<const CentrelinePoint> points, std::size_t first,
                         std::size_t count, float px_per_mm, const PieceLimits& limits,
                         std::vector<std::uint32_t>& kept) {
  kept.clear();
  if (count == 0) return;
  const std::size_t last = first + count - 1;
  kept.push_back(static_cast<std::uint32_t>(first));
  float length = 0, turning = 0, lift_turning = 0;  // of the piece so far
  for (std::size_t i = first + 1; i < last; ++i) {
    length += points[i - 1].length_mm * px_per_mm;
    // Would the piece still be fine reaching on to the next point?
    const float reach = length + points[i].length_mm * px_per_mm;
    const float bend = turning + points[i].turn;
    const float lift_bend = lift_turning + points[i].lift_turn;
    const bool straight_enough = reach * bend / 8 <= limits.tolerance_px;
    const bool level_enough = reach / px_per_mm * lift_bend / 4 <= limits.lift_tolerance;
    const bool must = points[i].keep;
    if ((must || reach > limits.max_px || !straight_enough || !level_enough) &&
        (must || length >= limits.min_px)) {
      kept.push_back(static_cast<std::uint32_t>(i));
      length = turning = lift_turning = 0;
      continue;
    }
    turning = bend;
    lift_turning = lift_bend;
  }
  if (last > first) kept.push_back(static_cast<std::uint32_t>(last));
}

void append_layered_strips(std::span<const std::uint32_t> kept, std::span<const std::uint8_t> layers,
                           std::size_t last, std::array<std::vector<std::uint32_t>, kLayers>& indices) {
  if (kept.size() < 2) return;
  // Runs of one layer, each at least three points long (shorter ones join
  // the run before, or the first run the one after).
  thread_local std::vector<std::uint8_t> layer;
  layer.assign(layers.begin(), layers.end());
  std::size_t start = 0;
  for (std::size_t k = 1; k <= layer.size(); ++k) {
    if (k < layer.size() && layer[k] == layer[start]) continue;
    if (k - start < 3) {
      const std::uint8_t joined = start > 0 ? layer[start - 1] : (k < layer.size() ? layer[k] : layer[start]);
      for (std::size_t j = start; j < k; ++j) layer[j] = joined;
    }
    start = k;
  }
  std::vector<std::uint32_t>* out = nullptr;
  std::size_t run_start = 0;
  std::uint32_t previous = 0;
  const auto draw = [&](std::uint32_t point, std::uint32_t ceiling) {
    if (out->size() > run_start && (point & 1U) == (previous & 1U)) {
      // The neighbour of the right parity: behind, else ahead.
      if (point - 1 > previous)
        --point;
      else if (point < ceiling)
        ++point;
      else
        return;
    }
    out->push_back(point);
    previous = point;
  };
  const auto close = [&] {
    if (out == nullptr) return;
    if (out->size() - run_start < 3)
      out->resize(run_start);
    else
      out->push_back(kRestartIndex);
  };
  for (std::size_t k = 0; k < kept.size(); ++k) {
    const std::uint32_t point = kept[k];
    const std::uint32_t ceiling =
        k + 1 < kept.size() ? kept[k + 1] : static_cast<std::uint32_t>(last);
    if (out == nullptr || &indices[layer[k]] != out) {
      if (out != nullptr) {
        draw(point, ceiling);  // the cut point ends this run and starts the next
        close();
      }
      out = &indices[layer[k]];
      run_start = out->size();
      out->push_back(point);
      previous = point;
      continue;
    }
    if (k + 1 == kept.size() && (point & 1U) == (previous & 1U) && point - 1 > previous)
      draw(point - 1, point);  // so that the very last point is drawn
    draw(point, ceiling);
  }
  close();
}

}  // namespace psrig::preview
