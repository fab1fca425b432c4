#pragma once
// The far level's texture (issue 30): one repeat of the cloth drawn at the
// near level, flat, orthographic along the view's direction, into a
// texture whose levels (and the summed-area table of one of them) the
// stitch mesh is drawn with from afar (far_cloth.h). This is chen2003-lumislice-knitwear.txt section 5.2.2's
// prefiltered slices taken to the cloth's repeat: each coarser level
// averages density (the paper's rho', eq. 11: here coverage, the mean of
// the four texels') and colour weighted by it (premultiplied colour, the
// plain mean), so coverage is resolved in depth by the near level itself
// (loops over loops hide what lies behind them) and only then averaged,
// never composited as if the yarns were independent. The colour comes from
// two bakes, over black and over white: what shows through a texel is
// their difference, whatever blending the near level does (its halo is
// blended "over").

#include <optional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "psrig/cloth/yarn_curves.h"
#include "psrig/preview/knit_view.h"

namespace psrig::preview {

// One repeat of the stitch mesh, the one nearest its middle: its corner
// and edges (a parallelogram, mm) and the faces it spans.
struct RepeatWindow {
  Eigen::Vector3f origin, across, up;
  int first_column = 0, first_row = 0, columns = 0, rows = 0;

  [[nodiscard]] Eigen::Vector3f centre() const { return origin + 0.5f * (across + up); }
  [[nodiscard]] Eigen::Vector3f normal() const { return across.cross(up).normalized(); }
};

[[nodiscard]] std::optional<RepeatWindow> middle_repeat(const cloth::YarnSurface& surface);

// The yarns near `window` (within `margin_mm` of it, what can be seen or
// cast a shadow there): runs of at least three points of each curve, the
// style, no surface.
[[nodiscard]] cloth::YarnSet window_yarns(const cloth::YarnSet& yarns, const RepeatWindow& window,
                                          float margin_mm);

// The frame that draws `window` onto a whole viewport looking back along
// `toward_eye` (unit), orthographic (KnitFrame::orthographic): a point of
// the window's plane lands where its (s, t) in the window say, whatever the
// direction, so the texture maps onto the mesh by face coordinates. The
// light and the shadow map are `seen`'s (the frame the cloth is drawn in).
[[nodiscard]] KnitFrame repeat_frame(const KnitFrame& seen, const RepeatWindow& window,
                                     const Eigen::Vector3f& toward_eye, float texels_per_mm,
                                     float depth_mm);

// The texture's texels from the two bakes (8-bit sRGB BGR frames as
// OffscreenTarget::read gives them, top row first): CV_32FC4, premultiplied
// linear R, G, B and coverage, bottom row first (GL's t up the window).
// Linear in what the bakes show, so bakes of the same repeat (its yarns'
// phases) are averaged by averaging these.
[[nodiscard]] cv::Mat repeat_texels(const cv::Mat& over_black, const cv::Mat& over_white);

// The texture's levels, `texels` first, down to 1x1. Sides must be powers
// of two (each level halves them exactly, so the repeat stays periodic at
// every level).
[[nodiscard]] std::vector<cv::Mat> repeat_levels(const cv::Mat& texels);

// A level's summed-area table (Crow 1984, "Summed-area tables for texture
// mapping"): what lets far_cloth.frag take the exact mean over a pixel's
// footprint, however many texels it covers, in four lookups. `sums` holds
// the sums over [0, x) x [0, y) of the level tiled 2x2 (a footprint up to
// a repeat wide then never wraps), for x in [0, 2W] and y in [0, 2H]:
// (2H + 1) x (2W + 1), CV_32FC4. The level's mean is taken off each texel
// before summing (kept in `mean`), so the sums stay near zero and float32
// keeps the small differences a footprint's mean is made of.
struct AreaTable {
  cv::Mat sums;
  cv::Vec4f mean;
};
[[nodiscard]] AreaTable repeat_area_table(const cv::Mat& level);

}  // namespace psrig::preview
