#pragma once
// Charts checked against the maps by knitting them (analysis by
// synthesis): a candidate repeat's knit and purl stitches are knitted by the
// cloth model (stitch_templates.h's render_chart_repeat) and the rendered
// heights correlated with the maps folded onto the same repeat, at every
// cyclic shift. A stitch's look depends on its neighbours (a 1x1 rib's purl
// wales hide behind the knit ones, garter's courses crowd into ridges), so
// the whole repeat is compared, never a stitch alone.

#include <optional>

#include <opencv2/core.hpp>

#include "psrig/analysis/stitch_templates.h"
#include "psrig/cloth/stitch_chart.h"
#include "stitch_period.h"

namespace psrig::analysis::inference {

// The best normalised correlation over every cyclic shift of two periodic
// images of one size, and that shift: the fold at (row, column) matches
// the render at (row - shift_row, column - shift_col).
struct Match {
  double score = -2;
  int shift_row = 0, shift_col = 0;
};
[[nodiscard]] Match circular_match(cv::Mat folded, cv::Mat rendered);

struct Synthesis {
  cloth::StitchChart chart;  // knit and purl only: no colours, no gauge
  Match match;
  float tightness = 0;  // the yarn it matched best with (knit_gauge.h)
  float yarn_mm = 0;
};

// The knit and purl stitches of the repeat `folded` holds (period.rows x n
// rows by period.columns x n columns, as inference::fold lays them) that,
// knitted at this wale and course spacing, match it best.
//
// first_labelling() is cheap: every labelling of a small repeat, knitted in
// full with the yarn loose, usual and tight; for a larger repeat, the lone
// faces' readings knitted as drafts. A larger repeat's first labelling is
// then worth refining (needs_refining()) when it is the best candidate:
// refine_labelling() flips one stitch at a time where the knitted draft
// matches better, then knits the result in full, the yarn loose, usual and
// tight. Nothing when no labelling could be knitted.
[[nodiscard]] std::optional<Synthesis> first_labelling(const cv::Mat& folded, Period period,
                                                       float wale_mm, float course_mm,
                                                       const StitchTemplates& lone);
[[nodiscard]] bool needs_refining(Period period);
[[nodiscard]] std::optional<Synthesis> refine_labelling(const cv::Mat& folded, Period period,
                                                        float wale_mm, float course_mm,
                                                        Synthesis start);

}  // namespace psrig::analysis::inference
