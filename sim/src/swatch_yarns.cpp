#include "swatch_yarns.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

#include "psrig/cloth/knit_fabric.h"
#include "psrig/cloth/woven_fabric.h"
#include "psrig/cloth/yarn_spline.h"
#include "sim_hash.h"

namespace psrig::sim::detail {
namespace {

// Loops and threads are never quite where the pattern puts them: each is
// nudged about its place (never carried on to the next, so the gauge stays
// true on average). Knits: a loop by 3 % of a wale or course in the plane
// and 0.12 yarn radii in depth; wovens: a thread's spacing by 5 %, its
// wander over a few crossings by 5 % of the spacing, its crimp by 12 %.
constexpr double kLoopShift = 0.03;
constexpr double kLoopDepth = 0.12;
constexpr double kThreadSpacing = 0.05;
constexpr double kThreadWander = 0.05;
constexpr double kCrimp = 0.12;
// Dye lots and yarn lots vary by a percent or two from yarn to yarn.
constexpr double kShade = 0.02;
// Ply grooves, fibre relief and the soft blur of a yarn's surface, in
// proportion to the yarn.
constexpr double kGrooveOfThickness = 0.2;   // of the half-thickness
constexpr double kReliefOfThickness = 0.04;  // of the half-thickness
constexpr double kSmoothingOfDiameter = 0.05;
// A fabric's margin round what the camera sees, in stitches or threads.
constexpr int kMarginThreads = 3;
// Centreline points about this many pixels apart on average (a Catmull-Rom
// spline through the cloth's points, up to 4 of ours to one of its).
constexpr double kPointSpacingPx = 1.5;

// The fabric built and laid, before it is turned.
struct LaidCloth {
  cloth::YarnSet yarns;
  int warps = 0;       // wovens: yarns [0, warps) are warps, the rest wefts
  cv::Point2d pitch;   // mean wale (end) and course (pick) spacing, mm
  cv::Point2d repeat;  // the pattern's repeat, mm
  cv::Point2d corner;  // the cloth's origin (stitch (0, 0)'s lower left) on the mesh
  double yarn_diameter_mm = 0;
};

// Whole repeats covering `extent` mm, the margin and a repeat's phase.
int repeats_over(double extent, double pitch, double repeat) {
  return static_cast<int>(std::ceil((extent + 2 * kMarginThreads * pitch + repeat) / repeat));
}

// A pattern's repeat in stitches (columns, rows) or threads (warps, wefts),
// and its cloth of so many.
cv::Size repeat_of(const cloth::StitchChart& chart) {
  return {chart.columns, chart.rows};
}
cv::Size repeat_of(const cloth::WeaveMatrix& weave) {
  return {weave.warps, weave.wefts};
}
Result<cloth::KnitFabric> fabric_of(const cloth::StitchChart& chart, int columns, int rows) {
  return cloth::KnitFabric::build(chart, columns, rows, {});
}
Result<cloth::WovenFabric> fabric_of(const cloth::WeaveMatrix& weave, int warps, int wefts) {
  return cloth::WovenFabric::build(weave, warps, wefts, {});
}

Result<LaidCloth> lay(const SwatchPattern& pattern, cv::Size2d extent) {
  return std::visit(
      [&](const auto& cells) -> Result<LaidCloth> {
        const cv::Size repeat = repeat_of(cells);
        LaidCloth laid;
        laid.pitch = {10.0 / pattern.gauge.across_per_cm, 10.0 / pattern.gauge.along_per_cm};
        laid.repeat = {laid.pitch.x * repeat.width, laid.pitch.y * repeat.height};
        const int columns = repeat.width * repeats_over(extent.width, laid.pitch.x, laid.repeat.x);
        const int rows = repeat.height * repeats_over(extent.height, laid.pitch.y, laid.repeat.y);
        auto fabric = fabric_of(cells, columns, rows);
        if (!fabric) return std::unexpected(fabric.error());
        const cloth::StitchMesh mesh = fabric->mesh();
        fabric->update(mesh, laid.yarns);
        laid.warps = pattern.knitted() ? 0 : columns;
        // The mesh is centred on the origin (a knit's has a row of faces
        // more than courses, for the top course's heads).
        laid.corner = {-0.5 * mesh.columns * mesh.face_width_mm,
                       -0.5 * mesh.rows * mesh.face_height_mm};
        laid.yarn_diameter_mm = fabric->dimensions().yarn_diameter_mm;
        return laid;
      },
      pattern.cloth);
}

// Each loop (knits: along each course) or thread (wovens) nudged about its
// place by smooth noise keyed to the yarn, so no kink appears.
void nudge(LaidCloth& laid, bool knitted, std::uint64_t seed) {
  const double radius = 0.5 * laid.yarn_diameter_mm;
  for (std::size_t i = 0; i < laid.yarns.curves.size(); ++i) {
    cloth::YarnCurve& curve = laid.yarns.curves[i];
    const auto index = static_cast<std::int64_t>(i);
    const std::uint64_t key = hash_of(seed, 0x6E75646765, index);  // "nudge"
    const auto noise = [&](double t, std::int64_t channel) {
      return static_cast<double>(
          value_noise(static_cast<float>(t), static_cast<float>(channel), key));
    };
    if (knitted) {
      for (Eigen::Vector3f& p : curve.points) {
        // About two independent values a loop: each loop moves as a whole.
        const double t = 2.0 * p.x() / laid.pitch.x;
        p.x() += static_cast<float>(kLoopShift * laid.pitch.x * noise(t, 1));
        p.y() += static_cast<float>(kLoopShift * laid.pitch.y * noise(t, 2));
        p.z() += static_cast<float>(kLoopDepth * radius * noise(t, 3));
      }
      continue;
    }
    const bool warp = static_cast<int>(i) < laid.warps;
    const double spacing = warp ? laid.pitch.x : laid.pitch.y;
    const double pitch = warp ? laid.pitch.y : laid.pitch.x;
    const double offset = kThreadSpacing * spacing * jitter(key, 1);
    for (Eigen::Vector3f& p : curve.points) {
      const double along = warp ? p.y() : p.x();
      const double wander = kThreadWander * spacing * noise(along / (3.0 * pitch), 2);
      (warp ? p.x() : p.y()) += static_cast<float>(offset + wander);
      p.z() *= static_cast<float>(1.0 + kCrimp * noise(along / pitch, 3));
    }
  }
}

// Centreline points close enough for the pixel size, on a Catmull-Rom
// spline through the cloth's, so a yarn's surface shows no facets.
void refine(cloth::YarnSet& yarns, double px) {
  double length = 0;
  std::size_t segments = 0;
  for (const cloth::YarnCurve& curve : yarns.curves)
    for (std::size_t k = 1; k < curve.points.size(); ++k, ++segments)
      length += (curve.points[k] - curve.points[k - 1]).head<2>().norm();
  if (segments == 0) return;
  const int per_span = std::clamp(
      static_cast<int>(std::ceil(length / static_cast<double>(segments) / (kPointSpacingPx * px))),
      1, 4);
  if (per_span == 1) return;
  std::vector<cloth::YarnControlPoint> control;
  for (cloth::YarnCurve& curve : yarns.curves) {
    const bool coloured = !curve.colours.empty();
    control.resize(curve.points.size());
    for (std::size_t k = 0; k < curve.points.size(); ++k)
      control[k] = {curve.points[k], curve.normals[k], curve.lift[k],
                    coloured ? curve.colours[k] : Eigen::Vector3f::Zero()};
    cloth::sample_yarn(control, per_span, coloured, curve);
  }
}

// The yarn's colour runs along its raster path, shaded by its dye lot.
YarnLook look_of(const cloth::YarnCurve& curve, const cloth::RasterYarn& yarn,
                 const cloth::YarnStyle& style, std::uint64_t key) {
  YarnLook look;
  look.half_width_mm = static_cast<float>(yarn.half_width_mm);
  look.twist_pitch_mm = style.twist_pitch_mm;
  look.plies = style.plies;
  look.groove_mm = static_cast<float>(kGrooveOfThickness * yarn.half_height_mm);
  look.key = key;
  const float shade = static_cast<float>(1.0 + kShade * jitter(key, 7));
  const auto bgr = [&](const Eigen::Vector3f& rgb) {
    return cv::Vec3f(rgb.z(), rgb.y(), rgb.x()) * shade;
  };
  if (curve.colours.empty()) {
    look.run_end.push_back(std::numeric_limits<float>::infinity());
    look.run_bgr.push_back(bgr(style.colour));
    return look;
  }
  // Arc length as the rasteriser measures it: in 3-D, point to point.
  double s = 0;
  look.run_bgr.push_back(bgr(curve.colours.front()));
  for (std::size_t k = 1; k < yarn.path.size(); ++k) {
    const cloth::RasterVertex& a = yarn.path[k - 1];
    const cloth::RasterVertex& b = yarn.path[k];
    const double step = std::sqrt((b.x - a.x) * (b.x - a.x) + (b.y - a.y) * (b.y - a.y) +
                                  (b.z - a.z) * (b.z - a.z));
    // A new colour, not the same one blended with itself by the spline.
    if (!curve.colours[k].isApprox(curve.colours[k - 1], 1e-3f)) {
      look.run_end.push_back(static_cast<float>(s + 0.5 * step));
      look.run_bgr.push_back(bgr(curve.colours[k]));
    }
    s += step;
  }
  look.run_end.push_back(std::numeric_limits<float>::infinity());
  return look;
}

}  // namespace

Result<SwatchYarns> swatch_yarns(const SwatchPattern& pattern, cv::Size size, double px,
                                 double rotation_deg, std::uint64_t seed) {
  const double width = size.width * px;
  const double height = size.height * px;
  const double turn = rotation_deg * std::numbers::pi / 180.0;
  const double cosine = std::cos(turn);
  const double sine = std::sin(turn);
  // What the camera sees, in the fabric's own (unturned) frame.
  const cv::Size2d extent{width * std::abs(cosine) + height * std::abs(sine),
                          width * std::abs(sine) + height * std::abs(cosine)};
  if (!(pattern.gauge.across_per_cm > 0 && pattern.gauge.along_per_cm > 0))
    return std::unexpected(bad_input(pattern.file, "pattern",
                                     "the swatch has no pattern: load a chart or weave "
                                     "(sim::load_swatch_pattern)"));
  auto laid = lay(pattern, extent);
  if (!laid) {
    Error error = std::move(laid.error());
    if (error.file.empty()) error.file = pattern.file;
    return std::unexpected(std::move(error));
  }
  const std::uint64_t mixed = mix64(seed ^ 0x5357415443484553ull);
  nudge(*laid, pattern.knitted(), mixed);
  refine(laid->yarns, px);

  // The image's centre, anywhere within a repeat of the mesh's centre.
  const cv::Point2d centre{(0.5 * jitter(mixed, 1)) * laid->repeat.x,
                           (0.5 * jitter(mixed, 2)) * laid->repeat.y};
  // Turned counterclockwise about the image's centre (y up).
  for (cloth::YarnCurve& curve : laid->yarns.curves)
    for (Eigen::Vector3f& p : curve.points) {
      const double dx = p.x() - centre.x;
      const double dy = p.y() - centre.y;
      p.x() = static_cast<float>(centre.x + cosine * dx - sine * dy);
      p.y() = static_cast<float>(centre.y + sine * dx + cosine * dy);
    }

  SwatchYarns out;
  const Eigen::Vector2d origin(centre.x - 0.5 * width, centre.y - 0.5 * height);
  out.yarns = cloth::raster_yarns(laid->yarns, origin, size, px);
  const cloth::YarnStyle& style = laid->yarns.style;
  double deepest = std::numeric_limits<double>::max();
  for (std::size_t k = 0; k < out.yarns.size(); ++k) {
    const cloth::RasterYarn& yarn = out.yarns[k];
    for (const cloth::RasterVertex& v : yarn.path)
      deepest = std::min(deepest, v.z + 0.5 * yarn.half_height_mm);
    out.looks.push_back(look_of(laid->yarns.curves[k], yarn, style,
                                hash_of(mixed, 0x7961726E, static_cast<std::int64_t>(k))));
  }
  // Gaps show the deepest yarns' flanks and the fibres between them, not a hole.
  out.floor_mm = static_cast<float>(deepest == std::numeric_limits<double>::max() ? 0.0 : deepest);
  out.gap_bgr = out.looks.empty() ? cv::Vec3f(0.5f, 0.5f, 0.5f) : out.looks.front().run_bgr.front();
  const double half_thickness = style.radius_mm * style.flatness;
  out.smoothing_mm = kSmoothingOfDiameter * laid->yarn_diameter_mm;
  out.fibre_relief_mm = kReliefOfThickness * half_thickness;

  // Cloth point q: on the mesh q + corner, turned about the centre, then
  // pixels (row 0 at the top, 0 at the first pixel's centre).
  const cv::Point2d shift = laid->corner - centre;
  const double tx = cosine * shift.x - sine * shift.y;
  const double ty = sine * shift.x + cosine * shift.y;
  out.cloth_to_image = cv::Matx23d(cosine / px, -sine / px, (tx + 0.5 * width) / px - 0.5,
                                   -sine / px, -cosine / px, (0.5 * height - ty) / px - 0.5);
  return out;
}

}  // namespace psrig::sim::detail
