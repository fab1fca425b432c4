#pragma once
// Yarn centrelines of woven cloth: warp threads run down the image, weft
// threads (picks) across it, and at each crossing one passes over the other
// as a binary weave matrix says (durupinar2007 builds woven cloth the same
// way). Between crossings a thread's height eases along a half cosine, so
// floats over two picks (twill) stay up and single crossings (plain) undulate.

#include <cmath>
#include <cstdint>
#include <numbers>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "sim_hash.h"
#include "yarn_raster.h"

namespace psrig::sim::detail {

enum class Weave { plain, twill };

struct WeaveSpec {
  Weave weave = Weave::plain;
  double ends_per_cm = 24;   // warp threads
  double picks_per_cm = 22;  // weft threads
  double warp_width_mm = 0.34;
  double warp_thickness_mm = 0.16;
  double weft_width_mm = 0.34;
  double weft_thickness_mm = 0.16;
  double crimp_mm = 0.08;  // centreline height where a thread is over, minus that where under
};

struct WovenYarns {
  std::vector<Yarn> yarns;  // warps first, then wefts
  std::size_t warp_count = 0;
};

// Whether warp `end` passes over weft `pick`. The 2/2 twill shifts the plain
// over-two-under-two by one end per pick, so floats line up along a diagonal
// rising to the right (a right-hand twill, as in most denim).
[[nodiscard]] constexpr bool warp_over(Weave weave, std::int64_t end, std::int64_t pick) {
  const std::int64_t k = end + pick;
  if (weave == Weave::plain) return (k % 2 + 2) % 2 == 0;
  return (k % 4 + 4) % 4 < 2;
}

[[nodiscard]] inline WovenYarns make_woven_yarns(const WeaveSpec& spec, cv::Size2d extent,
                                                 std::uint64_t seed) {
  const double sx = 10.0 / spec.ends_per_cm;
  const double sy = 10.0 / spec.picks_per_cm;
  const double x_phase = 0.5 * (jitter(seed, 1) + 1.0) * 4.0 * sx;
  const double y_phase = 0.5 * (jitter(seed, 2) + 1.0) * 4.0 * sy;
  const std::int64_t end_begin = -3;
  const auto end_end = static_cast<std::int64_t>(std::ceil((extent.width + x_phase) / sx)) + 3;
  const std::int64_t pick_begin = -3;
  const auto pick_end = static_cast<std::int64_t>(std::ceil((extent.height + y_phase) / sy)) + 3;
  const std::uint64_t warp_key = hash_of(seed, 0x77617270);  // "warp"
  const std::uint64_t weft_key = hash_of(seed, 0x77656674);  // "weft"

  // Threads are never perfectly straight nor evenly spaced.
  constexpr double kSpacingJitter = 0.05;  // of the thread spacing
  constexpr double kWander = 0.05;         // of the thread spacing, over a few crossings
  constexpr double kCrimpJitter = 0.12;    // of the crimp
  constexpr int kStepsPerCrossing = 4;
  const auto end_x = [&](std::int64_t i) {
    return static_cast<double>(i) * sx - x_phase + kSpacingJitter * sx * jitter(warp_key, i);
  };
  const auto pick_y = [&](std::int64_t j) {
    return static_cast<double>(j) * sy - y_phase + kSpacingJitter * sy * jitter(weft_key, j);
  };

  // One thread: crossings at positions `at(k)` along it, over (+1) or under (-1).
  const auto thread = [&](std::int64_t index, std::uint64_t key, bool is_warp) {
    const std::int64_t begin = is_warp ? pick_begin : end_begin;
    const std::int64_t end = is_warp ? pick_end : end_end;
    const double across = is_warp ? end_x(index) : pick_y(index);
    const double pitch = is_warp ? sy : sx;
    const double spacing = is_warp ? sx : sy;
    const auto over = [&](std::int64_t k) {
      const bool w = is_warp ? warp_over(spec.weave, index, k) : warp_over(spec.weave, k, index);
      return (w == is_warp ? 1.0 : -1.0) * (1.0 + kCrimpJitter * jitter(key, index, k));
    };
    Yarn yarn;
    for (std::int64_t k = begin; k < end; ++k) {
      const double a = is_warp ? pick_y(k) : end_x(k);
      const double b = is_warp ? pick_y(k + 1) : end_x(k + 1);
      const double za = over(k);
      const double zb = over(k + 1);
      for (int step = 0; step < kStepsPerCrossing; ++step) {
        const double t = static_cast<double>(step) / kStepsPerCrossing;
        const double along = a + t * (b - a);
        const double blend = 0.5 * (1.0 - std::cos(std::numbers::pi * t));
        const double wander =
            kWander * spacing *
            value_noise(static_cast<float>(along / (3.0 * pitch)), static_cast<float>(index), key);
        const double z = 0.5 * spec.crimp_mm * (za + blend * (zb - za));
        if (is_warp) {
          yarn.path.push_back({across + wander, along, z});
        } else {
          yarn.path.push_back({along, across + wander, z});
        }
      }
    }
    yarn.half_width_mm = 0.5 * (is_warp ? spec.warp_width_mm : spec.weft_width_mm);
    yarn.half_height_mm = 0.5 * (is_warp ? spec.warp_thickness_mm : spec.weft_thickness_mm);
    return yarn;
  };

  WovenYarns out;
  for (std::int64_t i = end_begin; i < end_end; ++i)
    out.yarns.push_back(thread(i, warp_key, true));
  out.warp_count = out.yarns.size();
  for (std::int64_t j = pick_begin; j < pick_end; ++j) {
    out.yarns.push_back(thread(j, weft_key, false));
  }
  return out;
}

}  // namespace psrig::sim::detail
