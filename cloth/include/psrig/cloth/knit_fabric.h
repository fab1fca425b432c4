#pragma once
// Knitted cloth at yarn level: a stitch chart tiled over columns x rows
// stitches at a real gauge, its yarns laid on a stitch mesh (Yuksel et al.
// 2012, as huang2025-realtime-knit-deformation-rendering.txt uses it: one
// quad per stitch), one continuous yarn per course.
//
// The yarns are the chart's repeat (knit_cell.h) relaxed for the mesh's
// in-plane deformation (yarn_cell.h), so that at rest and stretched or
// sheared they touch and never pass through each other; each repeat is
// then carried onto the mesh's surface, the yarn's depth along its normal.
// Relaxed repeats are kept by deformation, so a frame that deforms the
// cloth as an earlier one did only places yarn.
//
// Axes and units as yarn_curves.h: courses along +x, wales along +y,
// millimetres; row 0 is the first course.

#include <map>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "psrig/base/error.h"
#include "psrig/cloth/knit_cell.h"
#include "psrig/cloth/knit_gauge.h"
#include "psrig/cloth/stitch_chart.h"
#include "psrig/cloth/stitch_mesh.h"
#include "psrig/cloth/relaxed_repeats.h"
#include "psrig/cloth/yarn_cell.h"
#include "psrig/cloth/yarn_curves.h"

namespace psrig::cloth {

struct KnitParameters {
  KnitGauge gauge;  // over the chart's; what is known of it (knit_gauge.h derives the rest)
  // Plies, twist and colour of the yarn; its size comes from the gauge.
  int plies = 2;
  float twist_pitch_mm = 1.4f;  // about 7 turns per cm
  Eigen::Vector3f colour{0.55f, 0.18f, 0.12f};  // linear RGB, where the chart has no palette
  int samples_per_span = 4;  // yarn points between key points
  ClothShape shape = ClothShape::flat;
  RelaxOptions relax;
};

class KnitFabric {
 public:
  // `chart` tiled over columns x rows stitches from its first row and
  // column; `colours`, when not empty, one linear RGB per stitch (row-major,
  // row 0 first), over the chart's palette. Bad input: a gauge no knit has
  // (knit_gauge.h), or colours that are not one per stitch.
  [[nodiscard]] static Result<KnitFabric> build(const StitchChart& chart, int columns, int rows,
                                                const KnitParameters& parameters,
                                                std::vector<Eigen::Vector3f> colours = {});

  // The mesh the yarns lie on, deformed as asked: columns x (rows + 1) faces
  // of the mean wale and course (the last row holds the top course's heads).
  [[nodiscard]] StitchMesh mesh(ClothDeformation deformation = {}) const;

  // One frame: each stitch's repeat relaxed for its own face's in-plane
  // deformation (blended from the table, relaxed_repeats.h), its yarn placed
  // on `mesh` into `yarns`, whose storage is reused. A cloth deformed alike
  // everywhere (the command line's stretch and shear) blends once.
  void update(const StitchMesh& mesh, YarnSet& yarns);
  // What update() gives as `yarns.surface` (the mesh, the chart's repeat in
  // faces), no yarn placed: all a renderer's far level may need.
  [[nodiscard]] YarnSurface surface(const StitchMesh& mesh) const;

  [[nodiscard]] const KnitDimensions& dimensions() const { return dimensions_; }
  [[nodiscard]] const KnitRepeatLayout& repeat() const { return repeat_; }
  [[nodiscard]] const StitchChart& chart() const { return chart_; }
  [[nodiscard]] int columns() const { return columns_; }
  [[nodiscard]] int rows() const { return rows_; }
  [[nodiscard]] YarnStyle style() const;
  // The cross-section contact keeps (yarn_clearance.h).
  [[nodiscard]] const YarnSection& section() const { return rest_.section; }
  // The relaxed repeat of the last update, and how its relaxation went.
  // How the repeat's relaxations went: the worst clearance and strain of
  // every deformation relaxed so far.

 private:
  StitchChart chart_;
  int columns_ = 0, rows_ = 0;
  KnitParameters parameters_;
  KnitDimensions dimensions_;
  KnitRepeatLayout repeat_;
  YarnCell rest_;
  std::vector<Eigen::Vector3f> colours_;  // per stitch; empty: the style's colour
  // The repeat relaxed for deformations as they come (shared by copies).
  std::shared_ptr<RelaxedRepeats> repeats_;
  std::vector<RelaxedRepeats::Blend> blends_;  // per stitch, this frame's
};

}  // namespace psrig::cloth
