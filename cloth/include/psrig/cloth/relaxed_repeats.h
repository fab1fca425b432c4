#pragma once
// A pattern repeat's relaxed shape under any in-plane deformation, fast
// enough for every frame: the repeat is relaxed (yarn_cell.h) at the nodes
// of a table of deformations, once each, when first needed, and a
// deformation between nodes blends its neighbours' relaxations, as Sperl,
// Narain and Wojtan's mechanics-aware yarn geometry interpolates
// precomputed periodic yarn simulations over strain (SIGGRAPH 2021).
//
// A deformation is taken in the course's frame (x along the course), where
// it is upper triangular: a = the stretch along the courses, b = the shear
// (sideways lean per unit up), c = the stretch along the wales. What is
// blended is each point's offset from the affine (unrelaxed) shape, which
// is small and smooth, so the blend needs few nodes: a table step of 1/8.

#include <array>
#include <map>
#include <vector>

#include <Eigen/Core>

#include "psrig/cloth/yarn_cell.h"

namespace psrig::cloth {

class RelaxedRepeats {
 public:
  explicit RelaxedRepeats(YarnCell rest, RelaxOptions options = {}, float step = 0.125f);

  // The repeat under `deformation` into `out` (storage reused): exact at a
  // table node, blended between nodes.
  void shape(const Eigen::Matrix2f& deformation, YarnCell& out);

  // The nodes the last shape() used: their relaxations' worst clearance
  // and strain, and how many there were.
  [[nodiscard]] const RelaxReport& last_report() const { return last_report_; }
  [[nodiscard]] int nodes_relaxed() const { return static_cast<int>(nodes_.size()); }
  [[nodiscard]] const YarnCell& rest() const { return rest_; }

 private:
  struct Node {
    std::vector<Eigen::Vector3f> offset;  // per point, relaxed minus affine
    RelaxReport report;
  };
  const Node& node(const std::array<int, 3>& index);

  YarnCell rest_;
  RelaxOptions options_;
  float step_;
  std::map<std::array<int, 3>, Node> nodes_;
  RelaxReport last_report_;
};

}  // namespace psrig::cloth
