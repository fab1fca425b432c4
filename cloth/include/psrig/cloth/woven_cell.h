#pragma once
// A weave's repeat as yarn: one warp per matrix column running up the
// cloth, one weft per row running across it, each crossing its threads
// where the weave matrix says, with the crimp Peirce's geometry gives
// (F. T. Peirce, "The geometry of cloth structure", J. Textile Inst. 28,
// 1937): at a crossing the two threads touch, their centres one
// section-thickness apart, and between crossings a thread eases from one
// side to the other along a half cosine, so that floats (twill, satin) stay
// up and single crossings (plain) undulate. Woven yarn lies flattened,
// about twice as wide as thick.

#include <string>
#include <vector>

#include "psrig/base/error.h"
#include "psrig/cloth/yarn_cell.h"

namespace psrig::cloth {

// What is known of a woven cloth; 0 where not.
struct WovenGauge {
  float ends_per_cm = 0;   // warps
  float picks_per_cm = 0;  // wefts
  float yarn_diameter_mm = 0;
};

struct WovenDimensions {
  float end_spacing_mm = 0, pick_spacing_mm = 0;
  float yarn_diameter_mm = 0;  // round, before it is pressed flat
  float half_width_mm = 0;     // flattened, in the plane
  float half_thickness_mm = 0;
  // Peirce's cover: the fraction of the plane the warps and the wefts hide,
  // c1 + c2 - c1 c2 with c = width / spacing.
  float cover = 0;
  std::vector<std::string> notes;
};

// Nothing known: a cotton sheeting (Ne 16, 0.23 mm, 24 ends x 22 picks per
// cm). The yarn alone: spaced so its flattened width fills 80 % of the
// spacing. The densities alone: the yarn that does that. Threads too wide
// for their spacing to pass over and under each other (width over 1.3
// spacings) are bad input.
[[nodiscard]] Result<WovenDimensions> resolve_woven_gauge(const WovenGauge& gauge);

struct WeaveMatrix;

// The repeat's yarns at rest, warps first (periodic up the cloth), then
// wefts; `samples_per_crossing` points from one crossing to the next.
[[nodiscard]] YarnCell woven_rest_cell(const WeaveMatrix& weave, const WovenDimensions& dimensions,
                                       int samples_per_crossing = 8);

}  // namespace psrig::cloth
