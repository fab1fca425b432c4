#pragma once
// A stitch chart's repeat as yarn: one course of yarn per chart row, each
// loop a cardinal spline through key points (chen2003-lumislice-knitwear.txt
// section 4.1: key points per loop, interpolated by a cardinal spline), in
// the order the yarn runs: the sinker, the neck where the loop comes
// through the loop below, the leg, the leg top, the head and its crown, and
// down the other side.
//
// The key points are placed for the interlocking to be right: a knit loop's
// neck passes behind the legs of the loop below and in front of its head,
// so on the face its legs lie over the head below (the V's of jersey,
// leaning in toward the neck) and on the back the heads and sinkers show
// (purl bumps). A purl stitch is the same loop pulled through from the
// other side: its intermeshing mirrored along the normal.
//
// Charts with knit and purl side by side draw in: a purl wale between knit
// wales in the same rows (rib) sinks behind them and narrows, so the knit
// wales close over it; a purl course between knit courses (garter) stands
// out and the courses crowd together into ridges; where a stitch differs
// from its neighbours both across and up (seed) neither happens and the
// face is pebbled. The repeat's size follows the knit's dimensions
// (knit_gauge.h), scaled to a given gauge when there is one.

#include <vector>

#include "psrig/cloth/knit_gauge.h"
#include "psrig/cloth/stitch_chart.h"
#include "psrig/cloth/yarn_cell.h"

namespace psrig::cloth {

// How each column and row of a chart's repeat sits.
struct KnitRepeatLayout {
  std::vector<float> column_width_mm, column_x_mm;  // wale widths and centres
  // Each column's loops: a rib's purl wale narrows because its loops slip
  // behind the knit wales, not because they shrink.
  std::vector<float> loop_width_mm;
  std::vector<float> row_height_mm, row_y_mm;       // course heights and course lines
  float width_mm = 0, height_mm = 0;                // the repeat
};

// The yarn's drawn and touching sizes for a knit of yarn diameter d: seen
// head-on a knitted yarn is about 1.3 d wide (pressed flat, its fibres
// spread), 0.72 d thick; side by side two yarns pressed together keep 0.84 d apart.
struct KnitYarnSection {
  float half_width_mm = 0;      // drawn
  float half_thickness_mm = 0;  // drawn and touching
  float contact_radius_mm = 0;  // touching, in the plane
};
[[nodiscard]] KnitYarnSection knit_yarn_section(float yarn_diameter_mm);

// `gauge_scale`: the repeat stretched to the dimensions' wale and course
// spacing on average (true when a gauge was given: the measured gauge is
// the fabric's, draw-in included), else as drawn in from jersey.
[[nodiscard]] KnitRepeatLayout knit_repeat_layout(const StitchChart& chart,
                                                  const KnitDimensions& dimensions,
                                                  bool gauge_scale);

// The repeat's yarns at rest, `samples_per_span` points between key points.
[[nodiscard]] YarnCell knit_rest_cell(const StitchChart& chart, const KnitDimensions& dimensions,
                                      const KnitRepeatLayout& layout, int samples_per_span = 4);

}  // namespace psrig::cloth
