#pragma once
// What stitches look like head-on, as the cloth model knits them: the
// height over a chart's repeat, sampled on a square grid over each stitch's
// face of the stitch mesh (stitch_mesh.h). Chart inference
// (chart_inference.h) correlates a scan's stitch faces with these: a lone
// knit and purl face to find where the stitches lie, a whole candidate
// repeat to check a chart against the scan.

#include <opencv2/core.hpp>

#include "psrig/base/error.h"
#include "psrig/cloth/stitch_chart.h"

namespace psrig::analysis {

// The chart's repeat knitted at this wale and course spacing and yarn
// diameter (0: from the usual tightness, knit_gauge.h; the chart's own
// gauge and colours are ignored), relaxed and rasterised head-on, the
// middle repeat of a larger field: (rows x samples) x (columns x samples)
// CV_32F heights in mm. Row 0 is the top of the repeat's top course (the
// chart's last row), column 0 the left of its first column, as a scan
// shows the front. A draft has half the yarn points and a short relaxation (about
// eight times faster, the loops' shapes a little rougher): for ranking
// candidate charts, not for the final comparison. Bad input: a spacing no
// knit has.
[[nodiscard]] Result<cv::Mat> render_chart_repeat(const cloth::StitchChart& chart, float wale_mm,
                                                  float course_mm, float yarn_mm, int samples,
                                                  bool draft = false);

struct StitchTemplates {
  int samples = 0;  // per side
  // CV_32F samples x samples, zero mean and unit norm (ready for normalised
  // correlation), oriented as render_chart_repeat's: a face of stockinette
  // and one of reverse stockinette.
  cv::Mat knit;
  cv::Mat purl;
};

[[nodiscard]] Result<StitchTemplates> render_stitch_templates(float wale_mm, float course_mm,
                                                              int samples);

}  // namespace psrig::analysis
