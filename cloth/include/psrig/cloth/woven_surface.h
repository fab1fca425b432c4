#pragma once
// The fabric surface model's geometry (chen2024 3.1, after Jin et al. 2022):
// a weave's repeat as a height field of curved cylinders, one per visible
// yarn segment, giving at any point of the plane which yarn is seen (warp,
// weft or a gap), its ply normal n_p, ply orientation t_p and height x_p.
//
// We have only chen2024's summary of Jin 2022 ("each yarn is expressed as a
// curved cylinder, defined by the twist and inclination angle of the yarns,
// and the width and length of the yarns"; "the height field scaling factor
// beta ... affects both the normal n_p and orientation t_p"; gaps of 20 %),
// so the model below is ours, built to agree with that summary and with
// Irawan and Marschner 2012's yarn segments, which Jin's follow:
//
// - Units: one yarn spacing. Warp i runs along y at x = i + 1/2, weft j along
//   x at y = j + 1/2; the repeat is warps x wefts spacings (square cells:
//   ends and picks equally spaced). The cloth's front is +z (n_s).
// - Where each yarn is seen: a yarn covers a band (1 - gap) spacings wide
//   about its centre line. Where a warp band and a weft band cross, the weave
//   matrix says which is on top; where only one band lies, that yarn shows;
//   where none does (the gap squares at the cells' corners) the gap shows.
// - Along a yarn: each run of crossings where it lies over (a float) is one
//   circular arc of its centre line, convex, from cell edge to cell edge,
//   meeting the cloth's mid-plane at both ends at the inclination angle u;
//   each run where it lies under is the same arc concave. Consecutive arcs
//   meet with the same slope, so the centre line is smooth (C1). A float of
//   n crossings rises (n / 2) tan(u / 2) spacings: long floats stand higher,
//   as one arc per float implies (Irawan and Marschner's segment).
// - Across a yarn: its section is a circular arc whose edges, at the band's
//   edges, are tilted `section_edge_deg` from flat (60 degrees: the yarn
//   stands 0.58 half-widths above its edges, woven yarn lying flattened).
//   Departure: Irawan and Marschner's section is a full half cylinder (edges
//   at 90 degrees); ours keeps 1 / <n_s . n_p>, eq. (3)'s Jacobian, bounded
//   (2 at beta = 1), so a footprint's Monte Carlo estimate has finite
//   variance.
// - Height: x_p = beta (centre line + section) for the yarn seen, beta per
//   yarn type; a gap shows a black floor below every yarn. n_p is the normal
//   of that scaled height field, from its analytic gradient; the yarn's axis
//   T is the height field's tangent along the yarn; twist psi turns the ply
//   about n_p: t_p = cos(psi) T + sin(psi) n_p x T (Irawan and Marschner's
//   fibres at angle psi to the yarn axis). beta = 0 is flat; beta = 1 the
//   yarns' own shape.
// - Not modelled: the vertical walls where one yarn's edge stands above its
//   neighbour (they exist in the height field as steps; a ray meeting one
//   is stopped, eq. (3)'s V, but the wall is never shaded), plies within a
//   yarn (one ply a yarn, as chen2024), transmission (chen2024 adds a BTDF;
//   this surface only reflects).

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "psrig/base/error.h"
#include "psrig/cloth/weave_matrix.h"

namespace psrig::cloth {

enum class YarnType : std::uint8_t { gap = 0, warp = 1, weft = 2 };

// chen2024 5.1's gaps: the data set generator, the trainer's data and both
// renderers take this one value (the data set file does not record it).
inline constexpr float kWovenGapRatio = 0.2f;

// The yarns' shape, chen2024's Table 2 geometry (same for warp and weft).
struct YarnShape {
  float twist_deg = 0;          // psi: the ply's angle to the yarn's axis
  float inclination_deg = 30;   // u: the yarn's slope where it meets the mid-plane
  float gap_ratio = kWovenGapRatio;  // the part of a yarn spacing no yarn covers (chen2024 5.1)
  float section_edge_deg = 60;  // the section's slope at the yarn's edges (see above)
};

// What the eye sees at one point of the plane.
struct WovenPoint {
  YarnType yarn = YarnType::gap;
  float height = 0;                                       // x_p's z, spacings
  Eigen::Vector3f normal = Eigen::Vector3f::UnitZ();      // n_p (n_s in a gap)
  Eigen::Vector3f orientation = Eigen::Vector3f::Zero();  // t_p, unit (zero in a gap)
};

class WovenSurface {
 public:
  // Bad input for an empty weave, a gap ratio outside [0, 0.9), an
  // inclination outside (0, 80] degrees, a section edge outside (0, 85],
  // or a negative beta.
  [[nodiscard]] static Result<WovenSurface> make(const WeaveMatrix& weave, const YarnShape& shape,
                                                 float warp_beta = 1, float weft_beta = 1);

  // At (x, y) in spacings, anywhere (the repeat tiles the plane).
  [[nodiscard]] WovenPoint point(const Eigen::Vector2f& xy) const;
  [[nodiscard]] float height(const Eigen::Vector2f& xy) const;

  // Eq. (3)'s binary V: whether the ray from `from` towards `direction`
  // (unit, z > 0) leaves the cloth without passing under its height field.
  // Marched in steps of 1/25 spacing, so a yarn's edge a few hundredths of
  // a spacing wide can be missed.
  [[nodiscard]] bool visible(const Eigen::Vector3f& from, const Eigen::Vector3f& direction) const;

  // The first point of the height field a ray from above meets, or nothing
  // if it passes under no yarn within `max_distance` (a grazing ray).
  [[nodiscard]] std::optional<Eigen::Vector3f> first_hit(const Eigen::Vector3f& origin,
                                                         const Eigen::Vector3f& direction) const;

  [[nodiscard]] Eigen::Vector2f repeat_size() const {
    return {static_cast<float>(warps_), static_cast<float>(wefts_)};
  }
  [[nodiscard]] float top_height() const { return top_; }
  [[nodiscard]] float floor_height() const { return floor_; }
  [[nodiscard]] const YarnShape& shape() const { return shape_; }
  [[nodiscard]] float beta(YarnType yarn) const {
    return yarn == YarnType::weft ? weft_beta_ : warp_beta_;
  }

 private:
  // One yarn's run of crossings on the same side, as its centre line's arc.
  struct Run {
    std::int16_t start = 0;  // first crossing
    std::int16_t length = 0;
    bool over = false;
    bool flat = false;  // the yarn never changes side
  };
  struct Profile {
    float height = 0, slope = 0;
  };

  // `crossing` along the yarn (of `period`), `along` within it in [0, 1).
  [[nodiscard]] Profile centre_line(const Run& run, int crossing, float along, int period) const;
  [[nodiscard]] Profile section(float across) const;
  [[nodiscard]] YarnType yarn_at(const Eigen::Vector2f& xy, int& warp, int& weft, float& fx,
                                 float& fy) const;

  YarnShape shape_;
  int warps_ = 0, wefts_ = 0;
  float warp_beta_ = 1, weft_beta_ = 1;
  std::vector<std::uint8_t> over_;  // as WeaveMatrix::cells
  std::vector<Run> warp_runs_;      // [weft * warps + warp]: the warp's run at that crossing
  std::vector<Run> weft_runs_;      // [weft * warps + warp]: the weft's run there
  float half_width_ = 0.4f;         // the band's half width
  float section_radius_ = 0;        // the section arc's radius
  float section_rise_ = 0;          // its height above the band's edges
  float sin_u_ = 0, cos_u_ = 1;
  float top_ = 0, floor_ = 0;
};

}  // namespace psrig::cloth
