#include "psrig/cloth/yarn_cell.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>

#include <Eigen/LU>

namespace psrig::cloth {
namespace {

// Every point of the cell, flattened, with what contact needs to know.
struct PointIndex {
  std::vector<int> yarn, offset;  // per flat index: its yarn and its first flat index
  std::vector<float> arc;         // arc length from the yarn's first point, at rest
  std::vector<float> period_arc;  // per yarn: its length over one period, at rest
  std::vector<Eigen::Vector2i> period_cells;  // per yarn: its period in lattice steps
};

PointIndex index_points(const YarnCell& rest) {
  PointIndex index;
  const Eigen::Matrix2f lattice = (Eigen::Matrix2f() << rest.a1, rest.a2).finished();
  const Eigen::Matrix2f to_lattice = lattice.inverse();
  for (std::size_t y = 0; y < rest.yarns.size(); ++y) {
    const CellYarn& yarn = rest.yarns[y];
    const int first = static_cast<int>(index.yarn.size());
    float arc = 0;
    for (std::size_t k = 0; k < yarn.points.size(); ++k) {
      index.yarn.push_back(static_cast<int>(y));
      index.offset.push_back(first);
      index.arc.push_back(arc);
      const Eigen::Vector3f next = k + 1 < yarn.points.size()
                                       ? yarn.points[k + 1]
                                       : yarn.points[0] + Eigen::Vector3f(yarn.period.x(),
                                                                          yarn.period.y(), 0);
      arc += (next - yarn.points[k]).norm();
    }
    index.period_arc.push_back(arc);
    const Eigen::Vector2f steps = to_lattice * yarn.period;
    index.period_cells.emplace_back(static_cast<int>(std::lround(steps.x())),
                                    static_cast<int>(std::lround(steps.y())));
  }
  return index;
}

// The lattice shifts under which a point may meet another: enough images to
// cover every point's reach beyond its own repeat.
std::vector<Eigen::Vector2i> image_shifts(const YarnCell& cell, float reach) {
  const Eigen::Matrix2f lattice = (Eigen::Matrix2f() << cell.a1, cell.a2).finished();
  const Eigen::Matrix2f to_lattice = lattice.inverse();
  Eigen::Vector2f low = Eigen::Vector2f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector2f high = -low;
  for (const CellYarn& yarn : cell.yarns)
    for (const Eigen::Vector3f& p : yarn.points) {
      const Eigen::Vector2f s = to_lattice * p.head<2>();
      low = low.cwiseMin(s);
      high = high.cwiseMax(s);
    }
  // The reach in lattice steps along each axis, generously.
  const float reach_1 = reach * to_lattice.row(0).norm();
  const float reach_2 = reach * to_lattice.row(1).norm();
  const int k1 = static_cast<int>(std::ceil(high.x() - low.x() + reach_1)) + 1;
  const int k2 = static_cast<int>(std::ceil(high.y() - low.y() + reach_2)) + 1;
  std::vector<Eigen::Vector2i> shifts;
  for (int n = -k2; n <= k2; ++n)
    for (int m = -k1; m <= k1; ++m)
      shifts.emplace_back(m, n);
  return shifts;
}

// Points sorted into square bins of the contact distance, in the plane.
class Bins {
 public:
  Bins(const std::vector<Eigen::Vector3f>& points, float size) : size_(size) {
    entries_.reserve(points.size());
    for (std::size_t i = 0; i < points.size(); ++i)
      entries_.push_back({key(points[i].x(), points[i].y()), static_cast<int>(i)});
    std::sort(entries_.begin(), entries_.end());
  }
  // Calls visit(index) for every point in the 3x3 bins round (x, y).
  template <typename Visit>
  void around(float x, float y, Visit&& visit) const {
    const std::int64_t bx = cell(x), by = cell(y);
    for (std::int64_t dy = -1; dy <= 1; ++dy)
      for (std::int64_t dx = -1; dx <= 1; ++dx) {
        const std::int64_t k = pack(bx + dx, by + dy);
        auto it = std::lower_bound(entries_.begin(), entries_.end(), Entry{k, -1});
        for (; it != entries_.end() && it->key == k; ++it)
          visit(it->index);
      }
  }

 private:
  struct Entry {
    std::int64_t key;
    int index;
    bool operator<(const Entry& other) const {
      return key != other.key ? key < other.key : index < other.index;
    }
  };
  [[nodiscard]] std::int64_t cell(float v) const {
    return static_cast<std::int64_t>(std::floor(v / size_));
  }
  [[nodiscard]] static std::int64_t pack(std::int64_t x, std::int64_t y) {
    return (y << 32) ^ (x & 0xffffffff);
  }
  [[nodiscard]] std::int64_t key(float x, float y) const { return pack(cell(x), cell(y)); }
  float size_;
  std::vector<Entry> entries_;
};

// Calls visit(i, j, offset) for every pair of points that could touch:
// point j moved by `offset` (a lattice image) within `distance` of point i
// in the plane; pairs along one yarn closer than `exclusion` are skipped.
// The images are laid out once as ghosts round the cell's points, so each
// point looks in its own neighbourhood only.
template <typename Visit>
void for_each_contact_pair(const YarnCell& cell, const PointIndex& index,
                           const std::vector<Eigen::Vector3f>& flat,
                           const std::vector<Eigen::Vector2i>& shifts, float distance,
                           float exclusion, Visit&& visit) {
  Eigen::Vector2f low = Eigen::Vector2f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector2f high = -low;
  for (const Eigen::Vector3f& p : flat) {
    low = low.cwiseMin(p.head<2>());
    high = high.cwiseMax(p.head<2>());
  }
  low.array() -= distance;
  high.array() += distance;
  std::vector<Eigen::Vector3f> ghosts;
  std::vector<std::size_t> ghost_of;
  std::vector<Eigen::Vector2i> ghost_shift;
  for (const Eigen::Vector2i& shift : shifts) {
    const Eigen::Vector2f offset =
        static_cast<float>(shift.x()) * cell.a1 + static_cast<float>(shift.y()) * cell.a2;
    for (std::size_t j = 0; j < flat.size(); ++j) {
      const Eigen::Vector2f at = flat[j].head<2>() + offset;
      if ((at.array() < low.array()).any() || (at.array() > high.array()).any()) continue;
      ghosts.emplace_back(at.x(), at.y(), flat[j].z());
      ghost_of.push_back(j);
      ghost_shift.push_back(shift);
    }
  }
  const Bins bins(ghosts, distance);
  for (std::size_t i = 0; i < flat.size(); ++i) {
    const int yarn_i = index.yarn[i];
    bins.around(flat[i].x(), flat[i].y(), [&](int g) {
      const std::size_t j = ghost_of[static_cast<std::size_t>(g)];
      const Eigen::Vector2i& shift = ghost_shift[static_cast<std::size_t>(g)];
      if (j == i && shift.isZero()) return;
      if (index.yarn[j] == yarn_i) {
        // The same yarn, this many of its own periods on: near along it?
        const Eigen::Vector2i steps = index.period_cells[static_cast<std::size_t>(yarn_i)];
        const int turns = steps.x() != 0 ? shift.x() / steps.x()
                                         : (steps.y() != 0 ? shift.y() / steps.y() : 0);
        if (turns * steps.x() == shift.x() && turns * steps.y() == shift.y()) {
          const float along = index.arc[j] +
                              static_cast<float>(turns) *
                                  index.period_arc[static_cast<std::size_t>(yarn_i)] -
                              index.arc[i];
          if (std::abs(along) < exclusion) return;
        }
      }
      const Eigen::Vector2f offset =
          static_cast<float>(shift.x()) * cell.a1 + static_cast<float>(shift.y()) * cell.a2;
      visit(i, j, offset);
    });
  }
}

std::vector<Eigen::Vector3f> flatten(const YarnCell& cell) {
  std::vector<Eigen::Vector3f> flat;
  for (const CellYarn& yarn : cell.yarns)
    flat.insert(flat.end(), yarn.points.begin(), yarn.points.end());
  return flat;
}

void unflatten(const std::vector<Eigen::Vector3f>& flat, YarnCell& cell) {
  std::size_t i = 0;
  for (CellYarn& yarn : cell.yarns)
    for (Eigen::Vector3f& p : yarn.points)
      p = flat[i++];
}

Eigen::Vector3f deform(const Eigen::Matrix2f& f, const Eigen::Vector3f& p) {
  const Eigen::Vector2f xy = f * p.head<2>();
  return {xy.x(), xy.y(), p.z()};
}

// Half a turn round the section: closer than this along one yarn is the
// yarn's own neighbourhood, not a contact.
float exclusion_of(const YarnSection& section) {
  return std::numbers::pi_v<float> * section.contact_radius_mm;
}

}  // namespace

YarnCell deform_cell(const YarnCell& rest, const Eigen::Matrix2f& deformation) {
  YarnCell cell = rest;
  cell.a1 = deformation * rest.a1;
  cell.a2 = deformation * rest.a2;
  for (CellYarn& yarn : cell.yarns) {
    yarn.period = deformation * yarn.period;
    for (Eigen::Vector3f& p : yarn.points)
      p = deform(deformation, p);
  }
  return cell;
}

RelaxReport relax_cell(YarnCell& cell, const YarnCell& rest, const Eigen::Matrix2f& deformation,
                       const RelaxOptions& options) {
  const PointIndex index = index_points(rest);
  std::vector<Eigen::Vector3f> flat = flatten(cell);
  const std::size_t count = flat.size();
  // Rest lengths, the rest shape's second differences in the deformed frame,
  // and each point's affine place.
  std::vector<float> rest_length(count);
  std::vector<Eigen::Vector3f> rest_bend(count), anchor(count);
  std::vector<std::size_t> next(count), previous(count);
  std::vector<Eigen::Vector3f> next_shift(count, Eigen::Vector3f::Zero()),
      previous_shift(count, Eigen::Vector3f::Zero());
  {
    std::size_t i = 0;
    for (std::size_t y = 0; y < rest.yarns.size(); ++y) {
      const CellYarn& yarn = rest.yarns[y];
      const std::size_t n = yarn.points.size();
      const Eigen::Vector3f period(yarn.period.x(), yarn.period.y(), 0);
      const Eigen::Vector2f deformed_period = deformation * yarn.period;
      const Eigen::Vector3f shift(deformed_period.x(), deformed_period.y(), 0);
      for (std::size_t k = 0; k < n; ++k, ++i) {
        next[i] = i - k + (k + 1) % n;
        previous[i] = i - k + (k + n - 1) % n;
        if (k + 1 == n) next_shift[i] = shift;
        if (k == 0) previous_shift[i] = -shift;
        const Eigen::Vector3f after = k + 1 < n ? yarn.points[k + 1] : yarn.points[0] + period;
        const Eigen::Vector3f before = k > 0 ? yarn.points[k - 1] : yarn.points[n - 1] - period;
        rest_length[i] = (after - yarn.points[k]).norm();
        rest_bend[i] = deform(deformation, yarn.points[k] - 0.5f * (before + after));
        anchor[i] = deform(deformation, yarn.points[k]);
      }
    }
  }
  const YarnSection& section = rest.section;
  const float distance = 2 * section.contact_radius_mm;
  const float squash = section.contact_radius_mm / section.half_thickness_mm;  // z scale
  const float exclusion = exclusion_of(section);
  const std::vector<Eigen::Vector2i> shifts = image_shifts(cell, distance);

  // Gauss-Seidel sweeps in a fixed order (deterministic): lengths, then
  // curvature and place, then contacts. Contact pairs are looked for in a
  // wider radius every few sweeps, so none slips past between searches.
  struct Contact {
    std::size_t i, j;
    Eigen::Vector2f offset;
  };
  std::vector<Contact> pairs;
  constexpr int kSearchEvery = 4;
  constexpr float kSearchMargin = 1.4f;
  // Where yarn is crowded (a knit pushed together) contact takes longer to
  // settle: sweeps go on with contact and length alone until it has.
  int iteration = 0;
  const int planned = options.iterations;
  const auto settled = [&] {
    if (iteration < planned) return false;
    if (iteration >= options.max_iterations) return true;
    if ((iteration - planned) % 40 != 0) return false;
    unflatten(flat, cell);
    return min_clearance(cell) >= options.target_clearance;
  };
  for (; !settled(); ++iteration) {
    // The shape's pull eases over the last half, so that where the deformed
    // rest shape cannot fit, contact wins and the yarn finds another way.
    const float ease = std::clamp(2.0f * (1.0f - static_cast<float>(iteration) /
                                                     static_cast<float>(planned)),
                                  0.0f, 1.0f);
    for (std::size_t i = 0; i < count; ++i) {
      const std::size_t n = next[i];
      const Eigen::Vector3f d = flat[n] + next_shift[i] - flat[i];
      const float length = d.norm();
      if (length < 1e-9f) continue;
      const Eigen::Vector3f move =
          0.5f * options.stretch_stiffness * (length - rest_length[i]) / length * d;
      flat[i] += move;
      flat[n] -= move;
    }
    for (std::size_t i = 0; i < count; ++i) {
      const Eigen::Vector3f bend = flat[i] - 0.5f * (flat[previous[i]] + previous_shift[i] +
                                                     flat[next[i]] + next_shift[i]);
      flat[i] += ease * options.bend_stiffness * (rest_bend[i] - bend);
      // Held in the plane only: out of it the cloth may thicken where it is crowded.
      flat[i].head<2>() += ease * options.anchor_stiffness * (anchor[i] - flat[i]).head<2>();
    }
    if (iteration % kSearchEvery == 0) {
      pairs.clear();
      for_each_contact_pair(cell, index, flat, shifts, kSearchMargin * distance, exclusion,
                            [&](std::size_t i, std::size_t j, const Eigen::Vector2f& offset) {
                              if (i < j || (i == j && (offset.x() > 0 || (offset.x() == 0 && offset.y() > 0))))
                                pairs.push_back({i, j, offset});
                            });
    }
    for (const Contact& pair : pairs) {
      Eigen::Vector3f d = flat[pair.i] - flat[pair.j];
      d.x() -= pair.offset.x();
      d.y() -= pair.offset.y();
      d.z() *= squash;
      const float gap = d.norm();
      if (gap >= distance || gap < 1e-9f) continue;
      Eigen::Vector3f push = 0.5f * (distance - gap) / gap * d;
      push.z() /= squash;
      flat[pair.i] += push;
      flat[pair.j] -= push;
    }
  }
  unflatten(flat, cell);

  RelaxReport report;
  report.iterations = iteration;
  report.min_clearance = min_clearance(cell);
  for (std::size_t i = 0; i < count; ++i) {
    const float length = (flat[next[i]] + next_shift[i] - flat[i]).norm();
    report.max_strain = std::max(report.max_strain, std::abs(length / rest_length[i] - 1));
  }
  return report;
}

float min_clearance(const YarnCell& cell) {
  return closest_pair(cell).clearance;
}

ClosestPair closest_pair(const YarnCell& cell) {
  const PointIndex index = index_points(cell);
  const std::vector<Eigen::Vector3f> flat = flatten(cell);
  const YarnSection& section = cell.section;
  const float distance = 2 * section.contact_radius_mm;
  const float squash = section.contact_radius_mm / section.half_thickness_mm;
  const Eigen::Matrix2f to_lattice = (Eigen::Matrix2f() << cell.a1, cell.a2).finished().inverse();
  ClosestPair closest;
  closest.clearance = std::numeric_limits<float>::max();
  for_each_contact_pair(cell, index, flat, image_shifts(cell, distance), distance,
                        exclusion_of(section),
                        [&](std::size_t i, std::size_t j, const Eigen::Vector2f& offset) {
                          Eigen::Vector3f d = flat[i] - flat[j];
                          d.x() -= offset.x();
                          d.y() -= offset.y();
                          d.z() *= squash;
                          const float clearance = d.norm() / distance;
                          if (clearance >= closest.clearance) return;
                          const Eigen::Vector2f steps = to_lattice * offset;
                          closest = {clearance,
                                     index.yarn[i],
                                     static_cast<int>(i) - index.offset[i],
                                     index.yarn[j],
                                     static_cast<int>(j) - index.offset[j],
                                     {static_cast<int>(std::lround(steps.x())),
                                      static_cast<int>(std::lround(steps.y()))}};
                        });
  return closest;
}

}  // namespace psrig::cloth
