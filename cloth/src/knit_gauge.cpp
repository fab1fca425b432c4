#include "psrig/cloth/knit_gauge.h"

#include <cmath>
#include <spdlog/fmt/fmt.h>

namespace psrig::cloth {
namespace {

constexpr float kDiameterPerRootTex = 0.0505f;  // mm, at 0.5 g/cm^3
constexpr float kLoosest = 0.9f, kTightest = 2.2f;

// The loop length (mm) of a yarn at a tightness.
float loop_length_for(float diameter_mm, float tightness) {
  return std::sqrt(tex_from_yarn_diameter(diameter_mm)) / tightness;
}

}  // namespace

float yarn_diameter_from_tex(float tex) {
  return kDiameterPerRootTex * std::sqrt(tex);
}

float tex_from_yarn_diameter(float diameter_mm) {
  const float root = diameter_mm / kDiameterPerRootTex;
  return root * root;
}

Result<KnitDimensions> resolve_knit_gauge(const KnitGauge& gauge) {
  const auto check = [](float value, const char* key) -> Status {
    if (value < 0 || !std::isfinite(value))
      return std::unexpected(bad_input({}, key, fmt::format("{} must be positive", value)));
    return {};
  };
  if (auto ok = check(gauge.wales_per_cm, "wales_per_cm"); !ok) return std::unexpected(ok.error());
  if (auto ok = check(gauge.courses_per_cm, "courses_per_cm"); !ok)
    return std::unexpected(ok.error());
  if (auto ok = check(gauge.yarn_diameter_mm, "yarn_mm"); !ok) return std::unexpected(ok.error());

  KnitDimensions out;
  // Munden: l (mm) = 10 K / density.
  float loop = 0;
  if (gauge.wales_per_cm > 0 && gauge.courses_per_cm > 0) {
    loop = 0.5f * (10 * kMundenWales / gauge.wales_per_cm +
                   10 * kMundenCourses / gauge.courses_per_cm);
  } else if (gauge.wales_per_cm > 0) {
    loop = 10 * kMundenWales / gauge.wales_per_cm;
  } else if (gauge.courses_per_cm > 0) {
    loop = 10 * kMundenCourses / gauge.courses_per_cm;
  }
  float diameter = gauge.yarn_diameter_mm;
  if (diameter <= 0 && loop <= 0) {
    diameter = yarn_diameter_from_tex(66);
    out.notes.push_back(fmt::format("no gauge or yarn given: a 2/30 Nm yarn ({:.2f} mm)", diameter));
  }
  if (loop <= 0) {
    loop = loop_length_for(diameter, kDefaultTightness);
    out.notes.push_back(fmt::format("loop length {:.2f} mm from the yarn at tightness {:.1f} (Munden)",
                                    loop, kDefaultTightness));
  }
  if (diameter <= 0) {
    diameter = yarn_diameter_from_tex(std::pow(kDefaultTightness * loop, 2.0f));
    out.notes.push_back(
        fmt::format("yarn {:.2f} mm from the gauge at tightness {:.1f}", diameter, kDefaultTightness));
  }
  out.wale_mm = gauge.wales_per_cm > 0 ? 10 / gauge.wales_per_cm : loop / kMundenWales;
  out.course_mm = gauge.courses_per_cm > 0 ? 10 / gauge.courses_per_cm : loop / kMundenCourses;
  out.yarn_diameter_mm = diameter;
  out.loop_length_mm = loop;
  out.tightness_factor = std::sqrt(tex_from_yarn_diameter(diameter)) / loop;
  if (out.tightness_factor < kLoosest || out.tightness_factor > kTightest)
    return std::unexpected(bad_input(
        {}, "yarn_mm",
        fmt::format("a {:.2f} mm yarn at {:.1f} wales x {:.1f} courses per cm has tightness "
                    "factor {:.2f} (sqrt(tex) / loop length); knits hold together between {:.1f} "
                    "and {:.1f}: give a {} yarn or another gauge",
                    diameter, 10 / out.wale_mm, 10 / out.course_mm, out.tightness_factor,
                    kLoosest, kTightest, out.tightness_factor < kLoosest ? "thicker" : "thinner")));
  return out;
}

}  // namespace psrig::cloth
