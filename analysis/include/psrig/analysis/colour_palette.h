#pragma once
// A few colours for many: per-stitch mean colours of a scan quantised to
// the yarns a chart's palette names. Distances are CIE 1976 ΔE*ab in
// CIELAB (D65 white), where equal steps look about equally different;
// colours within `merge_delta_e` of a palette entry join it (the same
// yarn's stitches differ by shading and dye lot, a few ΔE).

#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>

namespace psrig::analysis {

struct ColourPalette {
  std::vector<Eigen::Vector3f> colours;  // linear RGB, most used first
  std::vector<std::uint8_t> index;       // per input colour, into colours
};

// Leader clustering in CIELAB, then k-means (Lloyd) from those leaders;
// entries holding under `min_share` of the colours join their nearest
// neighbour. At most `max_colours` entries (the most used kept); empty in,
// empty out.
[[nodiscard]] ColourPalette quantise_colours(std::span<const Eigen::Vector3f> linear_rgb,
                                             float merge_delta_e = 10.0f, int max_colours = 8,
                                             float min_share = 0.02f);

// Linear sRGB (D65) to CIELAB, and the ΔE*ab between two linear colours.
[[nodiscard]] Eigen::Vector3f linear_rgb_to_lab(const Eigen::Vector3f& linear_rgb);
[[nodiscard]] float delta_e(const Eigen::Vector3f& linear_a, const Eigen::Vector3f& linear_b);

}  // namespace psrig::analysis
