#include "psrig/sim/swatch_model.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "crease_fill.h"
#include "knit_structure.h"
#include "sim_hash.h"
#include "woven_structure.h"
#include "yarn_raster.h"

namespace psrig::sim {
namespace {

using detail::jitter;

// Steepest flank of a yarn, tan(55 deg): past it, fibres fill the crease.
constexpr double kFibreSkirtSlope = 1.43;

constexpr std::array<std::pair<std::string_view, SwatchPattern>, 5> kNames{{
    {"jersey", SwatchPattern::jersey},
    {"rib", SwatchPattern::rib},
    {"garter", SwatchPattern::garter},
    {"plain", SwatchPattern::plain},
    {"twill", SwatchPattern::twill},
}};

// How a yarn looks close up: its colour and its twist.
struct YarnLook {
  cv::Vec3f bgr;          // linear reflectance, BGR
  double twist_pitch_mm;  // one full turn of the plies
  int plies;
  double groove_mm;  // depth of the groove between plies on top of the yarn
};

struct PatternSpec {
  bool knitted = true;
  detail::KnitSpec knit;
  detail::WeaveSpec weave;
  YarnLook yarn;  // knits: the yarn; woven: the warp
  YarnLook weft;
  double smoothing_mm;  // yarn surfaces are soft: a light blur rounds the kinks where sections meet
  double fibre_relief_mm;  // amplitude of fibre-scale roughness
};

// Physical figures. Knits are medium-gauge (about 14 gauge) knitwear:
// - 2/30 Nm yarn (66 tex) packed at about 0.5 g/cm^3 has a diameter of
//   sqrt(4 tex / (pi rho)) ~ 0.41 mm; knitted, it flattens to ~1.2x as wide;
// - relaxed plain knit has about 7 wales/cm and, at Munden's dry-relaxed
//   courses-to-wales ratio of about 1.3, about 9 courses/cm;
// - 2-ply yarn has about 7 turns/cm of ply twist (a turn every 1.4 mm);
// - a 1x1 rib draws in: the purl wales (0.5 mm) sink behind the knit wales
//   (1.3 mm), about 5.5 ribs/cm;
// - garter in a heavier wool (0.48 mm): its row gauge is about twice its
//   stitch gauge (say 20 stitches x 40 rows per 10 cm), here 6.25 wales and
//   12.5 courses per cm, and a ridge every 2 courses.
// Woven cloth:
// - plain: a sheeting of Ne 16 yarn (37 tex, d ~ 1/(28 sqrt(Ne)) in ~ 0.23 mm
//   by Peirce) at 24 ends x 22 picks per cm, flattened to ~2x as wide as thick;
// - twill: denim, Ne 7 warp (0.34 mm) at 26 ends/cm and Ne 10 weft (0.29 mm)
//   at 19 picks/cm, an indigo warp over an undyed weft.
PatternSpec spec_for(SwatchPattern pattern) {
  PatternSpec spec{};
  const YarnLook knit_yarn{{0.07f, 0.09f, 0.45f}, 1.4, 2, 0.035};
  switch (pattern) {
    case SwatchPattern::jersey:
      spec.knit = {detail::KnitStructure::jersey, 1.43, 1.43, 1.11, 0.42, 0.62, 0.36, 0, 0, 1.0};
      spec.yarn = knit_yarn;
      break;
    case SwatchPattern::rib:
      spec.knit = {detail::KnitStructure::rib, 1.3, 0.5, 1.11, 0.42, 0.62, 0.36, 0.4, -1.5, 0.8};
      spec.yarn = {{0.05f, 0.30f, 0.52f}, 1.4, 2, 0.035};
      break;
    case SwatchPattern::garter:
      spec.knit = {
          detail::KnitStructure::garter, 1.6, 1.6, 0.8, 0.48, 0.62, 0.36, -1.0, 0.6, 1.0, 0.1};
      spec.yarn = {{0.55f, 0.66f, 0.72f}, 1.6, 2, 0.015};
      break;
    case SwatchPattern::plain:
      spec.knitted = false;
      spec.weave = {detail::Weave::plain, 24, 22, 0.34, 0.16, 0.36, 0.16, 0.16};
      spec.yarn = {{0.50f, 0.62f, 0.68f}, 1.0, 2, 0.012};
      spec.weft = {{0.62f, 0.52f, 0.45f}, 1.0, 2, 0.012};
      break;
    case SwatchPattern::twill:
      spec.knitted = false;
      spec.weave = {detail::Weave::twill, 26, 19, 0.40, 0.20, 0.40, 0.18, 0.19};
      spec.yarn = {{0.20f, 0.07f, 0.04f}, 1.0, 2, 0.015};
      spec.weft = {{0.72f, 0.78f, 0.80f}, 1.0, 2, 0.012};
      break;
  }
  spec.smoothing_mm = spec.knitted ? 0.02 : 0.015;
  spec.fibre_relief_mm = spec.knitted ? 0.006 : 0.004;
  return spec;
}

// Per yarn: which look, its own slight shade, and its half-width.
struct YarnInfo {
  const YarnLook* look;
  cv::Vec3f bgr;
  float half_width_mm;
  std::uint64_t key;
};

// Normals from the height by central differences (one-sided at the borders),
// in camera axes: y up, so q takes the row above minus the row below.
cv::Mat normals_from_height(const cv::Mat& height, double px) {
  cv::Mat normal(height.size(), CV_32FC3);
  const int rows = height.rows;
  const int cols = height.cols;
  cv::parallel_for_(cv::Range(0, rows), [&](const cv::Range& range) {
    for (int r = range.start; r < range.end; ++r) {
      const int up = std::max(r - 1, 0);
      const int down = std::min(r + 1, rows - 1);
      const float qscale = up == down ? 0.0f : static_cast<float>(1.0 / ((down - up) * px));
      const auto* zu = height.ptr<float>(up);
      const auto* zd = height.ptr<float>(down);
      const auto* z = height.ptr<float>(r);
      auto* n = normal.ptr<cv::Vec3f>(r);
      for (int c = 0; c < cols; ++c) {
        const int left = std::max(c - 1, 0);
        const int right = std::min(c + 1, cols - 1);
        const float pscale = left == right ? 0.0f : static_cast<float>(1.0 / ((right - left) * px));
        const float p = (z[right] - z[left]) * pscale;
        const float q = (zu[c] - zd[c]) * qscale;
        const float inv = 1.0f / std::sqrt(p * p + q * q + 1.0f);
        n[c] = {-p * inv, -q * inv, inv};
      }
    }
  });
  return normal;
}

}  // namespace

std::optional<SwatchPattern> parse_swatch_pattern(std::string_view name) {
  for (const auto& [n, p] : kNames) {
    if (n == name) return p;
  }
  return std::nullopt;
}

std::string_view to_string(SwatchPattern pattern) {
  for (const auto& [n, p] : kNames) {
    if (p == pattern) return n;
  }
  return "unknown";
}

SwatchGauge swatch_gauge(SwatchPattern pattern) {
  const PatternSpec spec = spec_for(pattern);
  if (!spec.knitted) return {false, spec.weave.ends_per_cm, spec.weave.picks_per_cm};
  const detail::KnitSpec& k = spec.knit;
  const double wale_mm = k.structure == detail::KnitStructure::rib
                             ? 0.5 * (k.knit_wale_mm + k.purl_wale_mm)
                             : k.knit_wale_mm;
  return {true, 10.0 / wale_mm, 10.0 / k.course_mm};
}

Swatch make_swatch(const SwatchParams& params) {
  if (params.rotation_deg != 0 && params.size.width > 0 && params.size.height > 0) {
    // Render square enough to cover the turned frame, turn it about the
    // centre, keep the middle.
    SwatchParams square = params;
    square.rotation_deg = 0;
    const int side =
        static_cast<int>(std::ceil(std::hypot(params.size.width, params.size.height))) + 8;
    square.size = {side, side};
    Swatch big = make_swatch(square);
    if (big.height_mm.empty()) return big;
    const cv::Point2f centre(0.5f * static_cast<float>(side - 1),
                             0.5f * static_cast<float>(side - 1));
    cv::Mat turn = cv::getRotationMatrix2D(centre, params.rotation_deg, 1.0);
    turn.at<double>(0, 2) -= 0.5 * (side - params.size.width);
    turn.at<double>(1, 2) -= 0.5 * (side - params.size.height);
    Swatch swatch;
    swatch.pixel_size_mm = params.pixel_size_mm;
    cv::warpAffine(big.height_mm, swatch.height_mm, turn, params.size, cv::INTER_CUBIC,
                   cv::BORDER_REFLECT);
    cv::warpAffine(big.albedo, swatch.albedo, turn, params.size, cv::INTER_LINEAR,
                   cv::BORDER_REFLECT);
    swatch.normal = normals_from_height(swatch.height_mm, params.pixel_size_mm);
    return swatch;
  }
  Swatch swatch;
  swatch.pixel_size_mm = params.pixel_size_mm;
  if (params.size.width <= 0 || params.size.height <= 0 || !(params.pixel_size_mm > 0)) {
    return swatch;
  }
  const double px = params.pixel_size_mm;
  const cv::Size size = params.size;
  const cv::Size2d extent{size.width * px, size.height * px};
  const PatternSpec spec = spec_for(params.pattern);
  const std::uint64_t seed = detail::mix64(params.seed ^ 0x5357415443484553ull);

  // Yarn centrelines, and how each yarn looks.
  std::vector<detail::Yarn> yarns;
  std::vector<YarnInfo> info;
  const auto shade = [](const cv::Vec3f& bgr, std::uint64_t key) {
    // Dye lots and yarn lots vary by a percent or two from yarn to yarn.
    return bgr * static_cast<float>(1.0 + 0.02 * jitter(key, 7));
  };
  if (spec.knitted) {
    yarns = detail::make_knit_yarns(spec.knit, extent, seed);
    for (std::size_t k = 0; k < yarns.size(); ++k) {
      const std::uint64_t key = detail::hash_of(seed, 0x7961726E, static_cast<std::int64_t>(k));
      info.push_back(
          {&spec.yarn, shade(spec.yarn.bgr, key), static_cast<float>(yarns[k].half_width_mm), key});
    }
  } else {
    detail::WovenYarns woven = detail::make_woven_yarns(spec.weave, extent, seed);
    yarns = std::move(woven.yarns);
    for (std::size_t k = 0; k < yarns.size(); ++k) {
      const std::uint64_t key = detail::hash_of(seed, 0x7961726E, static_cast<std::int64_t>(k));
      const YarnLook* look = k < woven.warp_count ? &spec.yarn : &spec.weft;
      info.push_back(
          {look, shade(look->bgr, key), static_cast<float>(yarns[k].half_width_mm), key});
    }
  }
  // Gaps show the deepest yarns' flanks and the fibres between them, not a hole.
  double floor_mm = 0;
  for (const auto& yarn : yarns) {
    for (const auto& v : yarn.path)
      floor_mm = std::min(floor_mm, v.z + 0.5 * yarn.half_height_mm);
  }

  detail::YarnRaster raster =
      detail::rasterize_yarns(yarns, size, px, static_cast<float>(floor_mm), kFibreSkirtSlope);
  detail::fill_creases(raster, px, kFibreSkirtSlope);

  // Ply twist, fibre texture and colour on top of the yarn tubes.
  cv::Mat height(size, CV_32F);
  swatch.albedo.create(size, CV_32FC3);
  const cv::Vec3f gap_bgr = spec.yarn.bgr;
  cv::parallel_for_(cv::Range(0, size.height), [&](const cv::Range& range) {
    for (int r = range.start; r < range.end; ++r) {
      const auto* top = raster.top.ptr<float>(r);
      const auto* id = raster.yarn.ptr<int>(r);
      const auto* along = raster.along.ptr<float>(r);
      const auto* across = raster.across.ptr<float>(r);
      auto* h = height.ptr<float>(r);
      auto* albedo = swatch.albedo.ptr<cv::Vec3f>(r);
      for (int c = 0; c < size.width; ++c) {
        if (id[c] < 0) {
          h[c] = top[c];
          albedo[c] = gap_bgr;
          continue;
        }
        const YarnInfo& yarn = info[static_cast<std::size_t>(id[c])];
        const YarnLook& look = *yarn.look;
        const float a = across[c];
        const float s = along[c];
        // A ply boundary is a helix: seen from above, the angle round the
        // yarn is asin(across), and it advances one turn per twist pitch.
        const float turns = s / static_cast<float>(look.twist_pitch_mm) +
                            std::asin(a) * static_cast<float>(0.5 / std::numbers::pi);
        const float psi = static_cast<float>(look.plies) * turns;
        const float nearest = std::floor(psi + 0.5f);
        const float cosine = std::cos(static_cast<float>(std::numbers::pi) * psi);
        const float groove = cosine * cosine * cosine * cosine;  // narrow, between the plies
        const float crown = std::sqrt(std::max(0.0f, 1.0f - a * a));
        const float across_mm = a * yarn.half_width_mm;
        // Fibres run along the yarn: texture stretched along it, fine across it,
        // a little proud and a little lighter where they bunch.
        const float fibres = detail::value_noise(s / 0.4f, across_mm / 0.05f, yarn.key);
        h[c] = top[c] - static_cast<float>(look.groove_mm) * groove * crown +
               static_cast<float>(spec.fibre_relief_mm) * fibres;
        const bool odd_ply = (static_cast<std::int64_t>(nearest) & 1) != 0;
        const float variation = (odd_ply ? 1.025f : 0.975f) * (1.0f + 0.035f * fibres);
        albedo[c] = yarn.bgr * variation;
      }
    }
  });
  raster = {};

  // Below a quarter pixel the blur would do nothing visible.
  const double sigma_px = spec.smoothing_mm / px;
  if (sigma_px > 0.25) {
    cv::GaussianBlur(height, height, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REFLECT);
  }
  double lowest = 0;
  cv::minMaxLoc(height, &lowest);
  height -= lowest;
  swatch.height_mm = height;
  swatch.normal = normals_from_height(height, px);
  cv::min(swatch.albedo, cv::Scalar::all(0.9), swatch.albedo);
  cv::max(swatch.albedo, cv::Scalar::all(0.03), swatch.albedo);
  return swatch;
}

}  // namespace psrig::sim
