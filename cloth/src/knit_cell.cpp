#include "psrig/cloth/knit_cell.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

#include "catmull_rom.h"

namespace psrig::cloth {
namespace {

// Which intermeshing sets a key point's depth: the loop's own (with the
// course below, at its neck), the next one (where the course above comes
// through its head), or both (the legs, between the two).
enum class Governed { bottom, top, both };

// u across the wale in wale widths from its centre, v up in course heights
// from the course line, z along the normal in yarn radii for a knit
// intermeshing (a purl one mirrors it).
struct KeyPoint {
  float u, v, z;
  Governed by;
};

// Left half of a loop, from its neck to the crown; the right half mirrors
// it. The neck enters behind the leg tops of the loop below (v -0.05,
// u +-0.40) and comes forward inside that loop, the legs pass over its head
// (v 0.25-0.40 of this course) and lean out to the leg tops, which lie over
// the next course's necks; the head goes behind the next course's legs.
constexpr std::array<KeyPoint, 6> kHalfLoop{{
    {-0.24f, -0.02f, -1.10f, Governed::bottom},  // neck entry
    {-0.12f, 0.15f, 1.00f, Governed::bottom},    // foot
    {-0.22f, 0.55f, 0.80f, Governed::both},      // leg
    {-0.38f, 0.92f, 0.25f, Governed::top},       // leg top
    {-0.40f, 1.12f, -0.50f, Governed::top},      // head
    {0.00f, 1.25f, -1.00f, Governed::top},       // crown
}};
constexpr KeyPoint kSinker{0.5f, -0.08f, -1.00f, Governed::bottom};

// Draw-in (the simulator's tuned rib and garter, issue 16's gauge truth):
// in a rib a knit wale keeps 0.91 of a jersey wale and a purl wale 0.35,
// the purl loop is 0.8 as wide and sits 1.5 radii behind, the knit 0.4 in
// front; in garter the courses crowd to 0.65, the knit courses sink a
// radius, the purl ones stand 0.6 out and their heads rise 0.1 course.
constexpr float kRibKnitWidth = 0.91f, kRibPurlWidth = 0.35f, kRibPurlLoop = 0.8f;
constexpr float kRibKnitRise = 0.4f, kRibPurlRise = -1.5f;
constexpr float kGarterHeight = 0.65f, kGarterKnitRise = -1.0f, kGarterPurlRise = 0.6f;
constexpr float kGarterHeadLift = 0.1f;

bool is_purl(const StitchChart& chart, int column, int row) {
  return chart.at(column, row) == Stitch::purl;
}

// How much of a rib (differs from its neighbours across, matches up and
// down) and of garter (matches across, differs up or down) a stitch is.
struct Context {
  float rib = 0, garter = 0;
};
Context context_of(const StitchChart& chart, int column, int row) {
  const bool p = is_purl(chart, column, row);
  // A column between two of the other kind draws in fully, beside one half.
  const float across = 0.5f * (static_cast<float>(is_purl(chart, column - 1, row) != p) +
                               static_cast<float>(is_purl(chart, column + 1, row) != p));
  const float up = (is_purl(chart, column, row - 1) != p || is_purl(chart, column, row + 1) != p)
                       ? 1.0f
                       : 0.0f;
  return {across * (1 - up), up * (1 - across)};
}

float rise_of(const StitchChart& chart, int column, int row) {
  const Context c = context_of(chart, column, row);
  const bool p = is_purl(chart, column, row);
  return c.rib * (p ? kRibPurlRise : kRibKnitRise) +
         c.garter * (p ? kGarterPurlRise : kGarterKnitRise);
}

// Depth of a key point of loop (column, row), in radii.
float depth(const StitchChart& chart, const KeyPoint& key, int column, int row) {
  const auto at = [&](int course) {
    return (is_purl(chart, column, course) ? -key.z : key.z) + rise_of(chart, column, course);
  };
  switch (key.by) {
    case Governed::bottom:
      return at(row);
    case Governed::top:
      return at(row + 1);
    case Governed::both:
      break;
  }
  return 0.5f * (at(row) + at(row + 1));
}

}  // namespace

KnitYarnSection knit_yarn_section(float yarn_diameter_mm) {
  return {0.65f * yarn_diameter_mm, 0.36f * yarn_diameter_mm, 0.42f * yarn_diameter_mm};
}

KnitRepeatLayout knit_repeat_layout(const StitchChart& chart, const KnitDimensions& dimensions,
                                    bool gauge_scale) {
  KnitRepeatLayout layout;
  const int columns = chart.columns, rows = chart.rows;
  for (int column = 0; column < columns; ++column) {
    float factor = 0, loop = 0;
    for (int row = 0; row < rows; ++row) {
      const float rib = context_of(chart, column, row).rib;
      const bool purl = is_purl(chart, column, row);
      factor += 1 + rib * ((purl ? kRibPurlWidth : kRibKnitWidth) - 1);
      loop += 1 + rib * ((purl ? kRibPurlLoop : kRibKnitWidth) - 1);
    }
    layout.column_width_mm.push_back(dimensions.wale_mm * factor / static_cast<float>(rows));
    layout.loop_width_mm.push_back(dimensions.wale_mm * loop / static_cast<float>(rows));
  }
  for (int row = 0; row < rows; ++row) {
    float factor = 0;
    for (int column = 0; column < columns; ++column)
      factor += 1 + context_of(chart, column, row).garter * (kGarterHeight - 1);
    layout.row_height_mm.push_back(dimensions.course_mm * factor / static_cast<float>(columns));
  }
  const auto total = [](const std::vector<float>& v) { return std::accumulate(v.begin(), v.end(), 0.0f); };
  if (gauge_scale) {
    const float sx = dimensions.wale_mm * static_cast<float>(columns) / total(layout.column_width_mm);
    const float sy = dimensions.course_mm * static_cast<float>(rows) / total(layout.row_height_mm);
    for (float& w : layout.column_width_mm) w *= sx;
    for (float& w : layout.loop_width_mm) w *= sx;
    for (float& h : layout.row_height_mm) h *= sy;
  }
  float x = 0;
  for (const float w : layout.column_width_mm) {
    layout.column_x_mm.push_back(x + 0.5f * w);
    x += w;
  }
  float y = 0;
  for (const float h : layout.row_height_mm) {
    layout.row_y_mm.push_back(y);
    y += h;
  }
  layout.width_mm = x;
  layout.height_mm = y;
  return layout;
}

YarnCell knit_rest_cell(const StitchChart& chart, const KnitDimensions& dimensions,
                        const KnitRepeatLayout& layout, int samples_per_span) {
  const KnitYarnSection section = knit_yarn_section(dimensions.yarn_diameter_mm);
  const float radius = 0.5f * dimensions.yarn_diameter_mm;
  YarnCell cell;
  cell.a1 = {layout.width_mm, 0};
  cell.a2 = {0, layout.height_mm};
  cell.section = {section.contact_radius_mm, section.half_thickness_mm};
  const int columns = chart.columns, rows = chart.rows;
  const int per_span = std::max(samples_per_span, 1);
  std::vector<Eigen::Vector4f> weights;
  for (int j = 0; j < per_span; ++j)
    weights.push_back(catmull_rom_weights(static_cast<float>(j) / static_cast<float>(per_span)));

  for (int row = 0; row < rows; ++row) {
    const float course_y = layout.row_y_mm[static_cast<std::size_t>(row)];
    const float course_h = layout.row_height_mm[static_cast<std::size_t>(row)];
    std::vector<Eigen::Vector3f> control;
    std::vector<std::uint16_t> control_stitch;
    for (int column = 0; column < columns; ++column) {
      const auto c = static_cast<std::size_t>(column);
      const float centre = layout.column_x_mm[c];
      const float width = layout.column_width_mm[c];
      // The sinker on this loop's left, shared with the loop before it.
      const float sinker_z =
          0.5f * (depth(chart, kSinker, column - 1, row) + depth(chart, kSinker, column, row));
      control.emplace_back(centre - 0.5f * width, course_y + kSinker.v * course_h,
                           radius * sinker_z);
      control_stitch.push_back(static_cast<std::uint16_t>(column));
      const float loop_width = layout.loop_width_mm[c];
      const float head_lift = context_of(chart, column, row + 1).garter * kGarterHeadLift;
      const auto place = [&](const KeyPoint& key, float side) {
        const bool head = key.by == Governed::top && key.v > 1.05f;
        control.emplace_back(centre + side * key.u * loop_width,
                             course_y + (key.v + (head ? head_lift : 0.0f)) * course_h,
                             radius * depth(chart, key, column, row));
        control_stitch.push_back(static_cast<std::uint16_t>(column));
      };
      for (const KeyPoint& key : kHalfLoop)
        place(key, 1.0f);
      for (auto it = kHalfLoop.rbegin() + 1; it != kHalfLoop.rend(); ++it)
        place(*it, -1.0f);
    }
    // A closed cardinal spline: the control polygon repeats by the repeat's width.
    const auto n = static_cast<int>(control.size());
    const Eigen::Vector3f period(layout.width_mm, 0, 0);
    const auto at = [&](int k) {
      const int wrapped = ((k % n) + n) % n;
      const int turns = (k - wrapped) / n;
      return control[static_cast<std::size_t>(wrapped)] + static_cast<float>(turns) * period;
    };
    CellYarn yarn;
    yarn.period = cell.a1;
    for (int k = 0; k < n; ++k)
      for (const Eigen::Vector4f& w : weights) {
        yarn.points.push_back(w.x() * at(k - 1) + w.y() * at(k) + w.z() * at(k + 1) +
                              w.w() * at(k + 2));
        yarn.stitch.push_back(control_stitch[static_cast<std::size_t>(k)]);
      }
    cell.yarns.push_back(std::move(yarn));
  }
  return cell;
}

}  // namespace psrig::cloth
