#include "psrig/cloth/relaxed_repeats.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace psrig::cloth {
namespace {

// A third to three times its size, leaning up to 45 degrees.
constexpr float kLeast = 0.34f, kMost = 3.0f, kLean = 1.0f;

Eigen::Matrix2f node_deformation(const std::array<int, 3>& index, float step) {
  Eigen::Matrix2f f;
  f << 1 + step * static_cast<float>(index[0]), step * static_cast<float>(index[1]), 0,
      1 + step * static_cast<float>(index[2]);
  return f;
}

}  // namespace

RelaxedRepeats::RelaxedRepeats(YarnCell rest, RelaxOptions options, float step)
    : rest_(std::move(rest)), options_(options), step_(step) {
  std::size_t first = 0;
  for (const CellYarn& yarn : rest_.yarns) {
    first_.push_back(first);
    first += yarn.points.size();
  }
  const int stretch_low = static_cast<int>(std::floor((kLeast - 1) / step)) - 1;
  const int stretch_high = static_cast<int>(std::ceil((kMost - 1) / step)) + 1;
  const int lean = static_cast<int>(std::ceil(kLean / step)) + 1;
  low_ = {stretch_low, -lean, stretch_low};
  size_ = {stretch_high - stretch_low + 1, 2 * lean + 1, stretch_high - stretch_low + 1};
  nodes_.resize(static_cast<std::size_t>(size_[0] * size_[1] * size_[2]));
}

RelaxedRepeats::~RelaxedRepeats() = default;

const RelaxedRepeats::Node& RelaxedRepeats::node(const std::array<int, 3>& index) {
  const auto slot = static_cast<std::size_t>(
      ((index[0] - low_[0]) * size_[1] + (index[1] - low_[1])) * size_[2] + (index[2] - low_[2]));
  std::unique_ptr<Node>& found = nodes_[slot];
  if (found) return *found;
  const Eigen::Matrix2f f = node_deformation(index, step_);
  const YarnCell affine = deform_cell(rest_, f);
  YarnCell relaxed = affine;
  auto made = std::make_unique<Node>();
  made->report = relax_cell(relaxed, rest_, f, options_);
  for (std::size_t y = 0; y < affine.yarns.size(); ++y)
    for (std::size_t k = 0; k < affine.yarns[y].points.size(); ++k)
      made->offset.push_back(relaxed.yarns[y].points[k] - affine.yarns[y].points[k]);
  found = std::move(made);
  return *found;
}

RelaxedRepeats::Blend RelaxedRepeats::blend(const Eigen::Matrix2f& deformation) {
  // In the course's frame the deformation is upper triangular; what little
  // of the lower corner a curved mesh gives is left to the placement.
  const float a = std::clamp(deformation(0, 0), kLeast, kMost);
  const float b = std::clamp(deformation(0, 1), -kLean, kLean);
  const float c = std::clamp(deformation(1, 1), kLeast, kMost);
  const std::array<float, 3> at{(a - 1) / step_, b / step_, (c - 1) / step_};
  std::array<int, 3> base{};
  std::array<float, 3> fraction{};
  for (std::size_t i = 0; i < 3; ++i) {
    base[i] = static_cast<int>(std::floor(at[i]));
    fraction[i] = at[i] - static_cast<float>(base[i]);
    // On a node (to rounding), that node alone.
    if (fraction[i] > 1 - 1e-4f) {
      ++base[i];
      fraction[i] = 0;
    } else if (fraction[i] < 1e-4f) {
      fraction[i] = 0;
    }
  }
  Blend blend;
  blend.deformation << a, b, 0, c;
  for (int corner = 0; corner < 8; ++corner) {
    float weight = 1;
    std::array<int, 3> index = base;
    for (std::size_t i = 0; i < 3; ++i) {
      const bool up = (corner >> i) & 1;
      weight *= up ? fraction[i] : 1 - fraction[i];
      if (up) ++index[i];
    }
    if (weight <= 0) continue;
    blend.nodes[static_cast<std::size_t>(blend.count)] = &node(index);
    blend.weights[static_cast<std::size_t>(blend.count)] = weight;
    ++blend.count;
  }
  return blend;
}

void RelaxedRepeats::shape(const Eigen::Matrix2f& deformation, YarnCell& out) {
  const Blend mix = blend(deformation);
  out = deform_cell(rest_, mix.deformation);
  std::size_t i = 0;
  for (CellYarn& yarn : out.yarns)
    for (Eigen::Vector3f& p : yarn.points) p += mix.offset(i++);
}

RelaxReport RelaxedRepeats::report() const {
  RelaxReport worst{0, std::numeric_limits<float>::max(), 0};
  for (const std::unique_ptr<Node>& n : nodes_) {
    if (!n) continue;
    worst.iterations += n->report.iterations;
    worst.min_clearance = std::min(worst.min_clearance, n->report.min_clearance);
    worst.max_strain = std::max(worst.max_strain, n->report.max_strain);
  }
  return worst;
}

}  // namespace psrig::cloth
