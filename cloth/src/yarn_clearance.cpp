#include "psrig/cloth/yarn_clearance.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <unordered_map>
#include <vector>

namespace psrig::cloth {

YarnClearance min_clearance(const YarnSet& yarns, const YarnSection& section) {
  const float distance = 2 * section.contact_radius_mm;
  const float squash = section.contact_radius_mm / section.half_thickness_mm;
  const float exclusion = std::numbers::pi_v<float> * section.contact_radius_mm;
  struct Point {
    int curve, index;
    float arc;
  };
  std::vector<Point> points;
  for (std::size_t c = 0; c < yarns.curves.size(); ++c) {
    const YarnCurve& curve = yarns.curves[c];
    float arc = 0;
    for (std::size_t k = 0; k < curve.points.size(); ++k) {
      if (k > 0) arc += (curve.points[k] - curve.points[k - 1]).norm();
      points.push_back({static_cast<int>(c), static_cast<int>(k), arc});
    }
  }
  // Bins of the contact distance in 3-D (a draped cloth is not flat).
  const auto bin = [&](const Eigen::Vector3f& p) {
    return Eigen::Vector3i(static_cast<int>(std::floor(p.x() / distance)),
                           static_cast<int>(std::floor(p.y() / distance)),
                           static_cast<int>(std::floor(p.z() / distance)));
  };
  const auto key = [](const Eigen::Vector3i& b) {
    return (static_cast<std::int64_t>(b.x()) * 73856093) ^ (static_cast<std::int64_t>(b.y()) * 19349663) ^
           (static_cast<std::int64_t>(b.z()) * 83492791);
  };
  std::unordered_map<std::int64_t, std::vector<int>> bins;
  const auto position = [&](const Point& p) -> const Eigen::Vector3f& {
    return yarns.curves[static_cast<std::size_t>(p.curve)].points[static_cast<std::size_t>(p.index)];
  };
  for (std::size_t i = 0; i < points.size(); ++i)
    bins[key(bin(position(points[i])))].push_back(static_cast<int>(i));

  YarnClearance closest;
  closest.clearance = std::numeric_limits<float>::max();
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Point& a = points[i];
    const Eigen::Vector3f& pa = position(a);
    const Eigen::Vector3f& normal =
        yarns.curves[static_cast<std::size_t>(a.curve)].normals[static_cast<std::size_t>(a.index)];
    const Eigen::Vector3i b = bin(pa);
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const auto found = bins.find(key(b + Eigen::Vector3i(dx, dy, dz)));
          if (found == bins.end()) continue;
          for (const int j : found->second) {
            if (static_cast<std::size_t>(j) <= i) continue;
            const Point& other = points[static_cast<std::size_t>(j)];
            if (other.curve == a.curve && std::abs(other.arc - a.arc) < exclusion) continue;
            const Eigen::Vector3f d = position(other) - pa;
            const float along_normal = d.dot(normal);
            const Eigen::Vector3f in_plane = d - along_normal * normal;
            const float gap =
                std::sqrt(in_plane.squaredNorm() + squash * squash * along_normal * along_normal) /
                distance;
            if (gap < closest.clearance)
              closest = {gap, a.curve, a.index, other.curve, other.index};
          }
        }
  }
  return closest;
}

}  // namespace psrig::cloth
