#pragma once
// A pattern repeat's relaxed shape under any in-plane deformation, fast
// enough for every frame and every stitch: the repeat is relaxed
// (yarn_cell.h) at the nodes of a table of deformations, once each, when
// first needed, and a deformation between nodes blends its neighbours'
// relaxations, as Sperl, Narain and Wojtan's mechanics-aware yarn geometry
// interpolates precomputed periodic yarn simulations over strain
// (SIGGRAPH 2021).
//
// A deformation is taken in the course's frame (x along the course), where
// it is upper triangular: a = the stretch along the courses, b = the shear
// (sideways lean per unit up), c = the stretch along the wales. What is
// blended is each point's offset from the affine (unrelaxed) shape, which
// is small and smooth, so the blend needs few nodes: a table step of 1/8.
// The table covers a third to three times the rest size and leans to 45
// degrees; deformations beyond are clamped to it.

#include <array>
#include <cstddef>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "psrig/cloth/yarn_cell.h"

namespace psrig::cloth {

class RelaxedRepeats {
 public:
  explicit RelaxedRepeats(YarnCell rest, RelaxOptions options = {}, float step = 0.125f);
  ~RelaxedRepeats();

  struct Node {
    std::vector<Eigen::Vector3f> offset;  // per point (flattened over the yarns), relaxed minus affine
    RelaxReport report;
  };
  // Which nodes a deformation blends, and how much of each.
  struct Blend {
    Eigen::Matrix2f deformation;  // as taken: clamped, upper triangular
    std::array<const Node*, 8> nodes{};
    std::array<float, 8> weights{};
    int count = 0;
    // The blended offset of point `flat` (yarn by yarn, point by point).
    [[nodiscard]] Eigen::Vector3f offset(std::size_t flat) const {
      Eigen::Vector3f sum = Eigen::Vector3f::Zero();
      for (int i = 0; i < count; ++i) sum += weights[static_cast<std::size_t>(i)] * nodes[static_cast<std::size_t>(i)]->offset[flat];
      return sum;
    }
  };
  // Relaxes the nodes it needs that were not relaxed yet.
  [[nodiscard]] Blend blend(const Eigen::Matrix2f& deformation);

  // The repeat under `deformation` into `out` (storage reused): exact at a
  // table node, blended between nodes.
  void shape(const Eigen::Matrix2f& deformation, YarnCell& out);

  // The worst clearance and strain of the nodes relaxed so far, and how many.
  [[nodiscard]] RelaxReport report() const;
  [[nodiscard]] const YarnCell& rest() const { return rest_; }
  // Where each yarn's points start in the flattened numbering.
  [[nodiscard]] std::size_t first_point(std::size_t yarn) const { return first_[yarn]; }

 private:
  const Node& node(const std::array<int, 3>& index);

  YarnCell rest_;
  RelaxOptions options_;
  float step_;
  std::vector<std::size_t> first_;
  std::array<int, 3> low_{}, size_{};           // the table's index range
  std::vector<std::unique_ptr<Node>> nodes_;  // dense over the range
};

}  // namespace psrig::cloth
