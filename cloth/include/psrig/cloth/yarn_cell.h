#pragma once
// One repeat of cloth at yarn level, and its relaxation under an in-plane
// deformation so that yarns touch and never pass through each other.
//
// The cell holds the yarns of one pattern repeat (a chart's or a weave's),
// each as one period of a closed polyline: point k + count is point k moved
// by the yarn's period (a lattice vector). The cloth is the cell repeated
// by the lattice a1 (across) and a2 (up), so a cell's relaxed shape is the
// shape of the whole cloth under a uniform deformation: relaxing the repeat
// once stands for relaxing every stitch (the periodic yarn-level unit cell
// of Sperl, Narain and Wojtan, "Homogenized yarn-level cloth", SIGGRAPH
// 2020, and "Mechanics-aware deformation of yarn pattern geometry", 2021).
//
// Relaxation is position-based (Mueller et al. 2007) with Jacobi sweeps, so
// it is deterministic: yarn length kept (inextensible yarn, loop length
// conserved), the rest shape's curvature kept in the deformed frame (the
// yarn's bending stiffness and "memory"), and contact: two yarn points keep
// apart by the yarn's cross-section, an ellipsoid 2 contact radii wide in
// the cloth's plane and 2 half-thicknesses along its normal.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace psrig::cloth {

struct CellYarn {
  std::vector<Eigen::Vector3f> points;  // mm; x across, y up, z out of the front
  Eigen::Vector2f period{0, 0};         // in-plane lattice vector one period moves by
  // Per point, the stitch (knit: column of the repeat; woven: the crossing
  // along the thread) it belongs to, for colours and for placing it.
  std::vector<std::uint16_t> stitch;
};

// The cross-section contact sees.
struct YarnSection {
  float contact_radius_mm = 0.2f;  // half the distance two yarns side by side keep
  float half_thickness_mm = 0.1f;  // half the distance two stacked yarns keep
};

struct YarnCell {
  Eigen::Vector2f a1{1, 0}, a2{0, 1};  // the repeat's lattice
  std::vector<CellYarn> yarns;
  YarnSection section;
};

// `rest` with every point's in-plane part mapped by `deformation` (z kept).
[[nodiscard]] YarnCell deform_cell(const YarnCell& rest, const Eigen::Matrix2f& deformation);

struct RelaxOptions {
  int iterations = 160;      // with the rest shape's pull, easing off over the second half
  int max_iterations = 1200;  // then contact and length alone, until target_clearance
  float target_clearance = 0.98f;
  float stretch_stiffness = 0.9f;  // per sweep, of the segment's length error
  float bend_stiffness = 0.3f;     // per sweep, of the curvature error
  float anchor_stiffness = 0.01f;  // toward the affine shape: keeps yarns where they belong
};

struct RelaxReport {
  int iterations = 0;
  float min_clearance = 0;  // min_clearance() after
  float max_strain = 0;     // largest |segment length / rest length - 1|
};

// Relaxes `cell` (which starts as deform_cell(rest, deformation), or from a
// nearby relaxed state) toward rest's yarn lengths and curvature under the
// deformation, with contact. `rest` and `cell` have the same yarns and points.
RelaxReport relax_cell(YarnCell& cell, const YarnCell& rest, const Eigen::Matrix2f& deformation,
                       const RelaxOptions& options = {});

// The smallest distance between two points of yarn that may touch, over
// the contact distance (1: touching; below 1: yarns pass into each other),
// across the cell's periodic images. Points closer along one yarn than half
// a turn round its own cross-section are not a contact.
[[nodiscard]] float min_clearance(const YarnCell& cell);

// Where the closest pair is: yarn and point of each, the second one in
// the lattice image `image` (steps along a1, a2).
struct ClosestPair {
  float clearance = 0;
  int yarn_a = 0, point_a = 0, yarn_b = 0, point_b = 0;
  Eigen::Vector2i image{0, 0};
};
[[nodiscard]] ClosestPair closest_pair(const YarnCell& cell);

}  // namespace psrig::cloth
