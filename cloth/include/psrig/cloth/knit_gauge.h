#pragma once
// A knit's size in millimetres from what a knitter or a lab knows of it: the
// gauge (wales and courses per cm) and the yarn's diameter, any of them, the
// rest following from plain-knit geometry:
// - Munden's constants (D. L. Munden, "The geometry and dimensional
//   properties of plain-knit fabrics", J. Textile Inst. 50, 1959): relaxed
//   plain knit has wales/cm = K_w / l and courses/cm = K_c / l for a loop
//   length l in cm, dry-relaxed K_w = 3.8 and K_c = 5.0, so the shape of a
//   loop does not depend on the yarn, only its size;
// - the tightness factor K = sqrt(tex) / l (l in mm; Munden, 1961), about
//   1.5 for ordinary knitwear, 1.2 loose, 1.8 tight;
// - the yarn's diameter from its linear density at a bulk density of about
//   0.5 g/cm^3 (spun yarn is half fibre, half air): d = sqrt(4 tex / (pi
//   rho)), d = 0.0505 sqrt(tex) mm.
// A 2/30 Nm (66 tex) yarn, d = 0.41 mm, at K = 1.5 gives l = 5.4 mm,
// 7.0 wales and 9.2 courses per cm: medium-gauge knitwear.

#include <string>
#include <vector>

#include "psrig/base/error.h"

namespace psrig::cloth {

inline constexpr float kMundenWales = 3.8f;    // K_w, dry relaxed
inline constexpr float kMundenCourses = 5.0f;  // K_c, dry relaxed
inline constexpr float kDefaultTightness = 1.5f;

// What is known; 0 where not.
struct KnitGauge {
  float wales_per_cm = 0;
  float courses_per_cm = 0;
  float yarn_diameter_mm = 0;
};

// A plain knit's dimensions (a jersey of this yarn and loop length; charts
// with rib or garter draw in from these, knit_cell.h).
struct KnitDimensions {
  float wale_mm = 0;    // wale spacing, 10 / wales per cm
  float course_mm = 0;  // course spacing
  float yarn_diameter_mm = 0;
  float loop_length_mm = 0;    // yarn in one loop, Munden's l
  float tightness_factor = 0;  // sqrt(tex) / l
  std::vector<std::string> notes;  // what was derived, and warnings
};

// Nothing known: the 2/30 Nm yarn above. The yarn alone: Munden at the
// usual tightness. Wales or courses alone: the loop length from Munden, the
// other density from it, the yarn from the usual tightness. Both densities:
// the loop length from their mean. Everything: kept as given; a tightness
// outside 0.9-2.2 (no such knit holds together, or it cannot be knitted) is
// bad input naming the figures. Densities and diameter must be positive
// where given.
[[nodiscard]] Result<KnitDimensions> resolve_knit_gauge(const KnitGauge& gauge);

// d = 0.0505 sqrt(tex) mm and back.
[[nodiscard]] float yarn_diameter_from_tex(float tex);
[[nodiscard]] float tex_from_yarn_diameter(float diameter_mm);

}  // namespace psrig::cloth
