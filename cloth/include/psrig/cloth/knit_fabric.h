#pragma once
// Knitted cloth at yarn level: a stitch layout laid on a stitch mesh, each
// loop's yarn built from control points around the knots where it
// interlocks with the loop below (its feet) and the loop above (its head),
// one continuous yarn per course (huang2025-realtime-knit-deformation-
// rendering.txt section 3; the control points play the part of the key
// points of chen2003-lumislice-knitwear.txt, interpolated by cardinal
// splines; knit and purl differ by the sign of their offsets along the
// normal, as durupinar2007-procedural-knit-woven.txt offsets its bonding
// points).
//
// Course r, stitch c, in the order the yarn runs (L, R: the stitch's left and
// right knots; face row r holds the feet of course r and the heads of
// course r - 1, so the mesh has one face row more than the layout):
//   sinker S(c, r) -> feet knot (c, r, L) -> head knot (c, r + 1, L)
//   -> head top H(c, r) -> head knot (c, r + 1, R) -> feet knot (c, r, R)
//   -> sinker S(c + 1, r)
// Sinkers and head tops follow the mesh; the knots are relaxed.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "psrig/cloth/knot_relaxation.h"
#include "psrig/cloth/stitch_chart.h"
#include "psrig/cloth/stitch_mesh.h"
#include "psrig/cloth/yarn_curves.h"

namespace psrig::cloth {

// The fabric's stitches (a chart tiled to size), as seen from the front.
struct KnitLayout {
  int columns = 0, rows = 0;
  std::vector<std::uint8_t> purl;        // row-major, row 0 the first course; 1: purl
  std::vector<Eigen::Vector3f> colours;  // per stitch, linear RGB; empty: the style's

  [[nodiscard]] bool is_purl(int column, int row) const {
    return purl[static_cast<std::size_t>(row * columns + column)] != 0;
  }
};

// The chart's repeat tiled over columns x rows, its first row the first
// course; colours from its palette when it has one.
[[nodiscard]] KnitLayout tile_chart(const StitchChart& chart, int columns, int rows);

struct KnitParameters {
  YarnStyle style;
  float stitch_width_mm = 5.0f;   // wale spacing at rest
  float course_height_mm = 4.0f;  // course spacing at rest
  float variation = 0.03f;        // random per-loop offsets, in stitch sizes
  std::uint32_t seed = 1;
  int samples_per_span = 4;  // yarn points per control point span
  int iterations = 3;        // Gauss-Newton iterations per knot and frame
  KnotWeights weights;
  ClothShape shape = ClothShape::flat;
};

class KnitFabric {
 public:
  [[nodiscard]] static KnitFabric build(const KnitLayout& layout, const KnitParameters& parameters);

  // The mesh the yarns follow, deformed as asked (layout columns x rows + 1).
  [[nodiscard]] StitchMesh mesh(ClothDeformation deformation = {}) const;

  // One frame: the knots follow `mesh`, are relaxed (or, with relax off,
  // only carried along by each face's deformation gradient: the naive
  // interpolation the knots improve on) and the yarns are sampled into
  // `yarns`, reusing its storage.
  void update(const StitchMesh& mesh, YarnSet& yarns, bool relax = true);

  // Introspection for tests and benchmarks, valid after update().
  [[nodiscard]] int knot_count() const { return static_cast<int>(knots_.size()); }
  [[nodiscard]] const KnotPlacement& placement(int knot) const { return placements_[knot]; }
  [[nodiscard]] KnotState state(int knot) const { return states_[knot]; }
  [[nodiscard]] KnotState initial_state(int knot) const { return initial_[knot]; }
  [[nodiscard]] std::span<const KnotPass> passes(int knot) const;
  [[nodiscard]] int knot_index(int column, int face_row, bool right) const {
    return (face_row * layout_.columns + column) * 2 + (right ? 1 : 0);
  }
  [[nodiscard]] const KnitLayout& layout() const { return layout_; }
  [[nodiscard]] const KnitParameters& parameters() const { return parameters_; }

 private:
  struct RestKnot {
    float u = 0, v = 0;  // in its face
    KnotState state;     // in the rest face's frame
    int pass_count = 0;  // passes[0]: course face_row (feet), then course face_row - 1 (head)
    std::array<KnotPass, 2> passes;
    std::array<int, 2> pass_course{};
  };
  struct FixedPoint {
    int column = 0, face_row = 0;
    float u = 0, v = 0, lift = 0;
  };

  void place(const StitchMesh& mesh);
  void link_passes(const StitchMesh& mesh);
  void sample(const StitchMesh& mesh, YarnSet& yarns) const;
  [[nodiscard]] Eigen::Vector3f fixed_position(const StitchMesh& mesh,
                                               const FixedPoint& point) const;
  [[nodiscard]] const FaceFrame& face_frame(int column, int face_row) const {
    return placements_[static_cast<std::size_t>(knot_index(column, face_row, false))].frame;
  }

  KnitLayout layout_;
  KnitParameters parameters_;
  std::vector<RestKnot> knots_;      // knot_index order
  std::vector<FixedPoint> sinkers_;  // (columns + 1) per course
  std::vector<FixedPoint> heads_;    // columns per course
  // This frame's.
  std::vector<KnotPlacement> placements_;
  std::vector<KnotState> initial_, states_;
};

}  // namespace psrig::cloth
