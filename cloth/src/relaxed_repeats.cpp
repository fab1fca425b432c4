#include "psrig/cloth/relaxed_repeats.h"

#include <algorithm>
#include <cmath>

namespace psrig::cloth {
namespace {

// The table covers what cloth survives: a third to three times its size,
// leaning up to 45 degrees.
constexpr float kLeast = 0.34f, kMost = 3.0f, kLean = 1.0f;

Eigen::Matrix2f node_deformation(const std::array<int, 3>& index, float step) {
  Eigen::Matrix2f f;
  f << 1 + step * static_cast<float>(index[0]), step * static_cast<float>(index[1]), 0,
      1 + step * static_cast<float>(index[2]);
  return f;
}

}  // namespace

RelaxedRepeats::RelaxedRepeats(YarnCell rest, RelaxOptions options, float step)
    : rest_(std::move(rest)), options_(options), step_(step) {}

const RelaxedRepeats::Node& RelaxedRepeats::node(const std::array<int, 3>& index) {
  auto it = nodes_.find(index);
  if (it != nodes_.end()) return it->second;
  const Eigen::Matrix2f f = node_deformation(index, step_);
  const YarnCell affine = deform_cell(rest_, f);
  YarnCell relaxed = affine;
  Node node;
  node.report = relax_cell(relaxed, rest_, f, options_);
  for (std::size_t y = 0; y < affine.yarns.size(); ++y)
    for (std::size_t k = 0; k < affine.yarns[y].points.size(); ++k)
      node.offset.push_back(relaxed.yarns[y].points[k] - affine.yarns[y].points[k]);
  return nodes_.emplace(index, std::move(node)).first->second;
}

void RelaxedRepeats::shape(const Eigen::Matrix2f& deformation, YarnCell& out) {
  // In the course's frame the deformation is upper triangular; what little
  // of the lower corner a curved mesh gives is left to the placement.
  const float a = std::clamp(deformation(0, 0), kLeast, kMost);
  const float b = std::clamp(deformation(0, 1), -kLean, kLean);
  const float c = std::clamp(deformation(1, 1), kLeast, kMost);
  const std::array<float, 3> at{(a - 1) / step_, b / step_, (c - 1) / step_};
  std::array<int, 3> base{};
  std::array<float, 3> fraction{};
  for (int i = 0; i < 3; ++i) {
    base[static_cast<std::size_t>(i)] = static_cast<int>(std::floor(at[static_cast<std::size_t>(i)]));
    fraction[static_cast<std::size_t>(i)] =
        at[static_cast<std::size_t>(i)] - static_cast<float>(base[static_cast<std::size_t>(i)]);
    // On a node (to rounding), that node alone.
    if (fraction[static_cast<std::size_t>(i)] > 1 - 1e-4f) {
      ++base[static_cast<std::size_t>(i)];
      fraction[static_cast<std::size_t>(i)] = 0;
    } else if (fraction[static_cast<std::size_t>(i)] < 1e-4f) {
      fraction[static_cast<std::size_t>(i)] = 0;
    }
  }
  Eigen::Matrix2f exact;
  exact << a, b, 0, c;
  out = deform_cell(rest_, exact);
  last_report_ = {0, 1e9f, 0};
  for (int corner = 0; corner < 8; ++corner) {
    float weight = 1;
    std::array<int, 3> index = base;
    for (int i = 0; i < 3; ++i) {
      const bool up = (corner >> i) & 1;
      const float f = fraction[static_cast<std::size_t>(i)];
      weight *= up ? f : 1 - f;
      if (up) ++index[static_cast<std::size_t>(i)];
    }
    if (weight <= 0) continue;
    const Node& n = node(index);
    last_report_.iterations += n.report.iterations;
    last_report_.min_clearance = std::min(last_report_.min_clearance, n.report.min_clearance);
    last_report_.max_strain = std::max(last_report_.max_strain, n.report.max_strain);
    std::size_t i = 0;
    for (CellYarn& yarn : out.yarns)
      for (Eigen::Vector3f& p : yarn.points)
        p += weight * n.offset[i++];
  }
}

}  // namespace psrig::cloth
