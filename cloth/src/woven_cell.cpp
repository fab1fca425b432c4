#include "psrig/cloth/woven_cell.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <spdlog/fmt/fmt.h>

#include "psrig/cloth/weave_matrix.h"

namespace psrig::cloth {
namespace {

constexpr float kHalfWidth = 0.74f;      // of the round diameter: pressed about twice as wide
constexpr float kHalfThickness = 0.35f;  // as thick
constexpr float kFill = 0.8f;            // flattened width over spacing, when one is derived
constexpr float kWidestFill = 1.3f;
// Contact sees a thread as rounder than it is drawn (a point of yarn is a
// small ellipsoid, not the swept flat section): flattened thread spreads
// sideways where there is room and gives way where there is not, so side
// by side it stops at a little more than its thickness.
constexpr float kContactRound = 1.15f;  // in-plane contact radius over the half-thickness

}  // namespace

Result<WovenDimensions> resolve_woven_gauge(const WovenGauge& gauge) {
  for (const auto& [value, key] : {std::pair{gauge.ends_per_cm, "ends_per_cm"},
                                   std::pair{gauge.picks_per_cm, "picks_per_cm"},
                                   std::pair{gauge.yarn_diameter_mm, "yarn_mm"}})
    if (value < 0 || !std::isfinite(value))
      return std::unexpected(bad_input({}, key, fmt::format("{} must be positive", value)));
  WovenDimensions out;
  float ends = gauge.ends_per_cm, picks = gauge.picks_per_cm, diameter = gauge.yarn_diameter_mm;
  if (ends <= 0 && picks <= 0 && diameter <= 0) {
    ends = 24, picks = 22, diameter = 0.23f;
    out.notes.push_back("no density or yarn given: a cotton sheeting, 24 ends x 22 picks per cm, 0.23 mm yarn");
  }
  if (ends <= 0 && picks > 0) ends = picks;
  if (picks <= 0 && ends > 0) picks = ends;
  if (diameter <= 0) {
    const float spacing = 0.5f * (10 / ends + 10 / picks);
    diameter = kFill * spacing / (2 * kHalfWidth);
    out.notes.push_back(fmt::format("yarn {:.2f} mm: flattened, it fills {:.0f} % of the spacing",
                                    diameter, 100 * kFill));
  }
  if (ends <= 0) {
    ends = picks = 10 / (2 * kHalfWidth * diameter / kFill);
    out.notes.push_back(fmt::format("{:.1f} ends and picks per cm: the yarn fills {:.0f} % of them",
                                    ends, 100 * kFill));
  }
  out.end_spacing_mm = 10 / ends;
  out.pick_spacing_mm = 10 / picks;
  out.yarn_diameter_mm = diameter;
  out.half_width_mm = kHalfWidth * diameter;
  out.half_thickness_mm = kHalfThickness * diameter;
  const float c1 = std::min(1.0f, 2 * out.half_width_mm / out.end_spacing_mm);
  const float c2 = std::min(1.0f, 2 * out.half_width_mm / out.pick_spacing_mm);
  out.cover = c1 + c2 - c1 * c2;
  const float fill = 2 * out.half_width_mm / std::min(out.end_spacing_mm, out.pick_spacing_mm);
  if (fill > kWidestFill)
    return std::unexpected(bad_input(
        {}, "yarn_mm",
        fmt::format("a {:.2f} mm yarn is {:.2f} mm wide woven, {:.1f} times its spacing at "
                    "{:.1f} ends x {:.1f} picks per cm: threads cannot pass over and under each "
                    "other; give a thinner yarn or fewer threads",
                    diameter, 2 * out.half_width_mm, fill, ends, picks)));
  return out;
}

YarnCell woven_rest_cell(const WeaveMatrix& weave, const WovenDimensions& dimensions,
                         int samples_per_crossing) {
  YarnCell cell;
  const float sx = dimensions.end_spacing_mm, sy = dimensions.pick_spacing_mm;
  cell.a1 = {sx * static_cast<float>(weave.warps), 0};
  cell.a2 = {0, sy * static_cast<float>(weave.wefts)};
  cell.section = {kContactRound * dimensions.half_thickness_mm, dimensions.half_thickness_mm};
  const int steps = std::max(samples_per_crossing, 2);
  // Centres one thickness apart where they cross: each half a thickness off the middle.
  const float depth = dimensions.half_thickness_mm;
  const auto thread = [&](bool warp, int index) {
    const int crossings = warp ? weave.wefts : weave.warps;
    const auto side = [&](int k) {
      const bool warp_over = warp ? weave.warp_over(index, k) : weave.warp_over(k, index);
      return warp_over == warp ? 1.0f : -1.0f;
    };
    CellYarn yarn;
    yarn.period = warp ? cell.a2 : cell.a1;
    const float across = (static_cast<float>(index) + 0.5f) * (warp ? sx : sy);
    const float pitch = warp ? sy : sx;
    // Peirce's thread wraps the crossing thread's flattened section, then
    // runs across to the next crossing: it holds its side over the other
    // thread's half-width and changes sides in between.
    const float hold = std::min(0.4f, dimensions.half_width_mm / pitch);
    for (int k = 0; k < crossings; ++k) {
      const float z0 = side(k), z1 = side(k + 1);
      for (int step = 0; step < steps; ++step) {
        const float t = static_cast<float>(step) / static_cast<float>(steps);
        const float eased = std::clamp((t - hold) / (1 - 2 * hold), 0.0f, 1.0f);
        const float blend = 0.5f * (1 - std::cos(std::numbers::pi_v<float> * eased));
        const float along = (static_cast<float>(k) + 0.5f + t) * pitch;
        const float z = depth * (z0 + blend * (z1 - z0));
        yarn.points.push_back(warp ? Eigen::Vector3f(across, along, z) : Eigen::Vector3f(along, across, z));
        // The span from crossing k to the next.
        yarn.stitch.push_back(static_cast<std::uint16_t>(k));
      }
    }
    return yarn;
  };
  for (int warp = 0; warp < weave.warps; ++warp)
    cell.yarns.push_back(thread(true, warp));
  for (int weft = 0; weft < weave.wefts; ++weft)
    cell.yarns.push_back(thread(false, weft));
  return cell;
}

}  // namespace psrig::cloth
