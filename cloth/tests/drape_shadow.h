#pragma once
// The shadow a draped cloth casts straight down, on a square grid about the
// origin: what a drape coefficient is measured from (Cusick's drape meter
// traces it on paper; here each triangle fills the cells whose centres it
// covers). Shared by the drape tests.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace psrig::cloth {

class DrapeShadow {
 public:
  // Cells `cell_mm` wide covering [-reach_mm, reach_mm] in both directions.
  DrapeShadow(float reach_mm, float cell_mm)
      : reach_(reach_mm),
        cell_(cell_mm),
        cells_(static_cast<int>(2 * reach_mm / cell_mm)),
        covered_(static_cast<std::size_t>(cells_) * static_cast<std::size_t>(cells_), 0) {}

  void cover(const Eigen::Vector2f& a, const Eigen::Vector2f& b, const Eigen::Vector2f& c) {
    const float area = cross(a, b, c);
    if (std::abs(area) < 1e-9f) return;
    const Eigen::Vector2f low = a.cwiseMin(b).cwiseMin(c), high = a.cwiseMax(b).cwiseMax(c);
    for (int j = std::max(0, index(low.y())); j <= std::min(cells_ - 1, index(high.y())); ++j)
      for (int i = std::max(0, index(low.x())); i <= std::min(cells_ - 1, index(high.x())); ++i) {
        const Eigen::Vector2f p((static_cast<float>(i) + 0.5f) * cell_ - reach_,
                                (static_cast<float>(j) + 0.5f) * cell_ - reach_);
        const float u = cross(b, c, p) / area, v = cross(c, a, p) / area;
        if (u >= 0 && v >= 0 && u + v <= 1) covered_[at(i, j)] = 1;
      }
  }

  [[nodiscard]] bool covers(const Eigen::Vector2f& p) const {
    const int i = index(p.x()), j = index(p.y());
    return i >= 0 && j >= 0 && i < cells_ && j < cells_ && covered_[at(i, j)] != 0;
  }

  [[nodiscard]] double area_mm2() const {
    double cells = 0;
    for (const std::uint8_t covered : covered_)
      cells += covered;
    return cells * cell_ * cell_;
  }

 private:
  static float cross(const Eigen::Vector2f& p, const Eigen::Vector2f& q, const Eigen::Vector2f& r) {
    return (q.x() - p.x()) * (r.y() - p.y()) - (q.y() - p.y()) * (r.x() - p.x());
  }
  [[nodiscard]] int index(float mm) const {
    return static_cast<int>(std::floor((mm + reach_) / cell_));
  }
  [[nodiscard]] std::size_t at(int i, int j) const {
    return static_cast<std::size_t>(j) * static_cast<std::size_t>(cells_) +
           static_cast<std::size_t>(i);
  }

  float reach_, cell_;
  int cells_;
  std::vector<std::uint8_t> covered_;
};

}  // namespace psrig::cloth
