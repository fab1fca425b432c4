#pragma once
// A knitted scan's stitch chart, read off its maps: which stitches are knit
// and which purl, where each stitch lies, its colour, and the gauge.
//
// The fabric measurement (processing/fabric_measure.h) gives a repeat
// lattice, u along the courses and v along the wales, but cannot count the
// stitches in it, and it may be smaller than the chart's repeat (knit and
// purl faces look alike enough that a seed stitch's measures one stitch).
// Here (method and figures: analysis/README.md "Chart inference"):
// 1. the stitch lattice: the split of the measured repeat into k x k'
//    stitches and its phase, from the maps folded onto the repeat and
//    correlated (normalised cross-correlation, Lewis 1995) with a lone knit
//    and purl face the cloth model renders (stitch_templates.h);
// 2. the chart's repeat from the stitches' faces alone (a stitch-level
//    autocorrelation) and their colours;
// 3. knit or purl by analysis by synthesis: candidate charts knitted by the
//    cloth model at the measured gauge and matched to the maps folded onto
//    their repeat, for the few splits worth checking; the best match wins
//    and places the lattice;
// 4. every stitch read on its own against the folded repeat's cells, its
//    colour quantised to a palette (colour_palette.h); the chart's gauge the
//    lattice's, its yarn the one the best match was knitted with.
//
// Conventions: the chart's row 0 is the bottom course, as in .chart files,
// and its stitch (0, 0) is the grid's bottom-left stitch. A chart is only
// defined up to a cyclic shift of its repeat (where the repeat starts is
// where the maps start); compare charts with same_chart_up_to_shift().

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "psrig/analysis/fabric_measure.h"
#include "psrig/base/error.h"
#include "psrig/cloth/stitch_chart.h"

namespace psrig::analysis {

// Where the stitches lie on the maps, pixels (x = column, y = row down).
struct StitchLattice {
  cv::Point2d origin_px;       // the bottom-left corner of stitch (0, 0)'s face
  cv::Point2d next_wale_px;    // one stitch along the course, to the right
  cv::Point2d next_course_px;  // one course up the wale (y decreasing)
  // The face corner of stitch (column, row).
  [[nodiscard]] cv::Point2d corner(double column, double row) const {
    return origin_px + column * next_wale_px + row * next_course_px;
  }
};

struct InferredKnit {
  // The repeat: knit and purl, a palette of the scan's colours (linear
  // RGB) and each cell's colour, the measured gauge (wales_per_cm,
  // courses_per_cm) and the yarn the knitted chart matched best with
  // (yarn_mm, to the tightness factor's steps); no gauge without a pixel
  // size. Named "inferred".
  cloth::StitchChart chart;
  StitchLattice lattice;
  // Every stitch whose face lies inside the maps: columns x rows, row-major,
  // row 0 the bottom course; each classified on its own.
  int columns = 0;
  int rows = 0;
  std::vector<cloth::Stitch> stitches;
  std::vector<Eigen::Vector3f> colours;  // mean albedo, linear RGB
  std::vector<std::uint8_t> colour_index;  // into chart.palette
  // Mean normalised correlation of the repeat's folded faces with the
  // better of the knit and purl faces (1: exactly the model's).
  double fit = 0;
  // Stitches that agree with the chart tiled over the grid.
  double agreement = 0;
  // Wales and courses per cm (per pixel without a pixel size), measured
  // across the wales and the course lines as fabric_measure.h does.
  double wales_per_cm = 0;
  double courses_per_cm = 0;
  bool per_pixel = false;
  // Stitches in the measured repeat: wales along its u, courses along its
  // v (FabricMeasurement::threads_u, threads_v counted).
  int wales_per_repeat = 1;
  int courses_per_repeat = 1;
  bool split_from_scan = false;  // those two given (ChartInferenceOptions), not counted
  std::vector<std::string> notes;
};

struct ChartInferenceOptions {
  int max_stitches_per_repeat = 16;  // each way
  int samples = 16;                  // per stitch face, each way
  // The stitches the measured repeat holds (wales, courses) where the scan
  // says so (scan.json's fabric.stitches_per_repeat): only that split is
  // tried. 0: counted on the maps.
  int known_wales_per_repeat = 0;
  int known_courses_per_repeat = 0;
};

// Options that take the stitches scan.json counts in a repeat (`hints`,
// analysis::fabric_hints) as the split, as `fabric` measured them: the
// rig's word (the simulator's, or the technician's), so only knit and purl
// are read off then.
[[nodiscard]] ChartInferenceOptions options_from_scan(const FabricMeasurement& fabric,
                                                      const FabricHints& hints);

// height: CV_32F (NaN: none); albedo: CV_32FC3 linear BGR (as the maps
// directory's albedo.exr), CV_32FC1, or empty (then no palette). `fabric`
// is the maps' measurement. Bad input naming the reason: a woven fabric
// (by the scan's metadata), no repeat, a repeat too small to hold a stitch,
// or faces that look like no knit or purl stitch.
[[nodiscard]] Result<InferredKnit> infer_knit_chart(const cv::Mat& height, const cv::Mat& albedo,
                                                    const FabricMeasurement& fabric,
                                                    const ChartInferenceOptions& options = {});

// The measurement with its stitches counted rather than assumed: the
// wales and courses in its repeat, and so its densities, from `knit`; the
// note on the assumption replaced by one on the count.
void count_stitches(FabricMeasurement& fabric, const InferredKnit& knit);

// The same stitches, both repeats tiled, whatever stitch each starts at:
// equal sizes and one cyclic shift that maps one onto the other (stitches
// only, not colours).
[[nodiscard]] bool same_chart_up_to_shift(const cloth::StitchChart& a, const cloth::StitchChart& b);

// The fraction of `grid` (columns x rows, row-major, row 0 the bottom) that
// agrees with `chart` tiled over it at the best cyclic shift of the chart.
[[nodiscard]] double agreement_with_chart(const std::vector<cloth::Stitch>& grid, int columns,
                                          int rows, const cloth::StitchChart& chart);

}  // namespace psrig::analysis
