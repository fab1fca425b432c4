#pragma once
// Yarn centrelines of weft-knitted fabric (jersey, 1x1 rib, garter), one
// continuous yarn per course, seen from the technical face.
//
// Each loop is a spline through key points (chen2003's scheme): the two legs
// run from the neck at the bottom centre of the wale up and out to the head,
// which curls over the top behind the next course's legs; sinker loops join
// neighbouring loops below the necks. On a knit stitch the legs are in front
// and the head and sinkers behind (the "V"); a purl stitch is the same loop
// seen from the back, head and sinkers in front (the purl bump).

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "catmull_rom.h"
#include "sim_hash.h"
#include "yarn_raster.h"

namespace psrig::sim::detail {

enum class KnitStructure { jersey, rib, garter };

struct KnitSpec {
  KnitStructure structure = KnitStructure::jersey;
  double knit_wale_mm = 1.43;  // width of a knit wale
  double purl_wale_mm = 1.43;  // width of a purl wale (1x1 rib only)
  double course_mm = 1.11;
  double yarn_diameter_mm = 0.42;
  double half_width = 0.62;      // cross-section half-width over the diameter (flattened yarn)
  double half_height = 0.36;     // cross-section half-height over the diameter
  double knit_rise = 0;          // radii added to the centreline at knit intermeshings
  double purl_rise = 0;          // radii added to the centreline at purl intermeshings
  double purl_loop_width = 1.0;  // purl loops' width over their wale's width
  double head_lift = 0;  // courses added to the height of the loop heads (garter's tilted loops)
};

namespace knit {

// Key points of one loop, left to right: u across the wale (wale widths, from
// its centre), v up the fabric (courses, from the neck's course line), and the
// centreline height in yarn radii where the governing intermeshing is knit
// and where it is purl. The feet and sinkers sit at the loop's own (bottom)
// intermeshing, the leg tops and head at the one above it, where the next
// course is pulled through; the legs' middles blend the two. At a knit
// intermeshing the neck rides forward over the old loop's head behind it, so
// a knit wale is thickest down its middle.
enum class Governed { bottom, top, both };
struct KeyPoint {
  double u, v, z_knit, z_purl;
  Governed by;
};
inline constexpr std::array<KeyPoint, 9> kLoop{{
    {-0.13, 0.06, 1.00, -0.70, Governed::bottom},  // left foot at the neck
    {-0.25, 0.52, 0.75, -0.90, Governed::both},    // left leg
    {-0.36, 0.96, 0.05, 0.20, Governed::top},      // left leg top, turning into the head
    {-0.31, 1.26, -0.75, 0.85, Governed::top},     // head
    {0.00, 1.40, -0.85, 1.00, Governed::top},
    {0.31, 1.26, -0.75, 0.85, Governed::top},
    {0.36, 0.96, 0.05, 0.20, Governed::top},
    {0.25, 0.52, 0.75, -0.90, Governed::both},
    {0.13, 0.06, 1.00, -0.70, Governed::bottom},  // right foot
}};
// Between two loops; u is placed at the wale boundary.
inline constexpr KeyPoint kSinker{0.0, -0.14, -0.70, 0.90, Governed::bottom};

[[nodiscard]] constexpr std::int64_t floor_div(std::int64_t a, std::int64_t b) {
  return a / b - ((a % b != 0) && ((a < 0) != (b < 0)) ? 1 : 0);
}

struct Layout {
  const KnitSpec& spec;
  [[nodiscard]] bool is_rib() const { return spec.structure == KnitStructure::rib; }
  [[nodiscard]] double pitch() const {
    return is_rib() ? 0.5 * (spec.knit_wale_mm + spec.purl_wale_mm) : spec.knit_wale_mm;
  }
  // Whether loop (wale, course) was drawn through the loop below it from the
  // front (purl) rather than from the back (knit), as seen on this face.
  [[nodiscard]] bool purl(std::int64_t wale, std::int64_t course) const {
    switch (spec.structure) {
      case KnitStructure::rib:
        return floor_div(wale, 2) * 2 != wale;
      case KnitStructure::garter:
        return floor_div(course, 2) * 2 != course;
      case KnitStructure::jersey:
        break;
    }
    return false;
  }
  [[nodiscard]] double width(std::int64_t wale) const {
    return is_rib() && purl(wale, 0) ? spec.purl_wale_mm : spec.knit_wale_mm;
  }
  [[nodiscard]] double centre(std::int64_t wale) const {
    if (!is_rib()) return static_cast<double>(wale) * spec.knit_wale_mm;
    const double pair = spec.knit_wale_mm + spec.purl_wale_mm;
    const std::int64_t q = floor_div(wale, 2);
    return static_cast<double>(q) * pair + (q * 2 != wale ? 0.5 * pair : 0.0);
  }
  [[nodiscard]] double rise(std::int64_t wale, std::int64_t course) const {
    return purl(wale, course) ? spec.purl_rise : spec.knit_rise;
  }
};

}  // namespace knit

// One yarn per course covering [0, extent] (mm, image axes) with a margin.
// The fabric grows up the image: course j + 1 lies above course j.
[[nodiscard]] inline std::vector<Yarn> make_knit_yarns(const KnitSpec& spec, cv::Size2d extent,
                                                       std::uint64_t seed) {
  const knit::Layout layout{spec};
  const double radius = 0.5 * spec.yarn_diameter_mm;
  const double pitch = layout.pitch();
  const double x_phase = 0.5 * (jitter(seed, 1) + 1.0) * 2.0 * pitch;
  const double y_phase = 0.5 * (jitter(seed, 2) + 1.0) * 2.0 * spec.course_mm;
  const double y_base = extent.height + y_phase;
  const std::int64_t wale_begin = -3;
  const auto wale_end = static_cast<std::int64_t>(std::ceil((extent.width + x_phase) / pitch)) + 3;
  const auto course_end = static_cast<std::int64_t>(std::ceil(y_base / spec.course_mm)) + 3;

  // Small per-loop variation: loops are never quite identical in real knits.
  constexpr double kJitterUV = 0.03;  // of a wale / a course
  constexpr double kJitterZ = 0.12;   // yarn radii
  constexpr double kJitterSize = 0.04;

  std::vector<Yarn> yarns;
  for (std::int64_t j = -3; j < course_end; ++j) {
    const std::uint64_t course_key = hash_of(seed, 0x6B6E6974, j);  // "knit"
    std::vector<YarnVertex> keys;
    const auto place = [&](double x, double v, double z, std::int64_t i, std::int64_t k) {
      keys.push_back({x - x_phase + kJitterUV * pitch * jitter(course_key, i, k, 1),
                      y_base - (static_cast<double>(j) + v) * spec.course_mm +
                          kJitterUV * spec.course_mm * jitter(course_key, i, k, 2),
                      radius * (z + kJitterZ * jitter(course_key, i, k, 3))});
    };
    // Height of a key point of loop (i, j), from the intermeshing(s) governing it.
    const auto z_of = [&](const knit::KeyPoint& p, std::int64_t i) {
      const auto at = [&](std::int64_t course) {
        return (layout.purl(i, course) ? p.z_purl : p.z_knit) + layout.rise(i, course);
      };
      switch (p.by) {
        case knit::Governed::bottom:
          return at(j);
        case knit::Governed::top:
          return at(j + 1);
        case knit::Governed::both:
          break;
      }
      return 0.5 * (at(j) + at(j + 1));
    };
    for (std::int64_t i = wale_begin; i <= wale_end; ++i) {
      // The sinker loop on this loop's left, shared with the loop before it.
      const double sinker_z = 0.5 * (z_of(knit::kSinker, i - 1) + z_of(knit::kSinker, i));
      place(layout.centre(i) - 0.5 * layout.width(i), knit::kSinker.v, sinker_z, i, 0);
      if (i == wale_end) break;
      const double size = 1.0 + kJitterSize * jitter(course_key, i, 99);
      const double loop_width =
          layout.width(i) * size * (layout.purl(i, j) ? spec.purl_loop_width : 1.0);
      for (std::size_t k = 0; k < knit::kLoop.size(); ++k) {
        const knit::KeyPoint& p = knit::kLoop[k];
        const double lift = k >= 3 && k <= 5 ? spec.head_lift : 0.0;
        place(layout.centre(i) + p.u * loop_width, p.v * size + lift, z_of(p, i), i,
              static_cast<std::int64_t>(k) + 1);
      }
    }
    Yarn yarn;
    yarn.path = sample_catmull_rom(keys, 0.3, 7.0 * std::numbers::pi / 180.0);
    yarn.half_width_mm = spec.half_width * spec.yarn_diameter_mm;
    yarn.half_height_mm = spec.half_height * spec.yarn_diameter_mm;
    yarns.push_back(std::move(yarn));
  }
  return yarns;
}

}  // namespace psrig::sim::detail
