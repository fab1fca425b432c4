#include "psrig/preview/scan_cloth.h"

#include <cmath>

#include <spdlog/fmt/fmt.h>

#include "psrig/analysis/maps_fabric.h"
#include "psrig/formats/maps_reader.h"

namespace psrig::preview {
namespace {

constexpr double kDeg = 180.0 / 3.14159265358979323846;

// Shear and spacings at rest of a lattice with steps `along` (one stitch
// or thread along the courses) and `up` (one up the wales), image pixels
// (y down): turned so that the courses run along x, the wales lean by the
// shear.
void rest_shape(cv::Point2d along, cv::Point2d up, double mm, ScanCloth& out, bool knit) {
  const cv::Point2d a(along.x, -along.y), b(up.x, -up.y);  // y up, as the cloth's
  const double turn = std::atan2(a.y, a.x);
  const double c = std::cos(turn), s = std::sin(turn);
  const cv::Point2d b_turned(c * b.x + s * b.y, -s * b.x + c * b.y);
  out.shear = static_cast<float>(b_turned.x / b_turned.y);
  const auto width = static_cast<float>(std::hypot(a.x, a.y) * mm);
  const auto height = static_cast<float>(b_turned.y * mm);
  (knit ? out.wale_mm : out.end_mm) = width;
  (knit ? out.course_mm : out.pick_mm) = height;
}

}  // namespace

std::vector<Eigen::Vector3f> ScanCloth::stitch_colours(int columns, int rows) const {
  std::vector<Eigen::Vector3f> colours;
  if (!knit || knit->chart.palette.empty()) return colours;
  for (int row = 0; row < rows; ++row)
    for (int column = 0; column < columns; ++column)
      colours.push_back(knit->chart.palette[static_cast<std::size_t>(
          knit->chart.colour_at(column, row))]);
  return colours;
}

ClothSize ScanCloth::cloth_size(ClothSize given, bool knitted) const {
  const auto per_cm = [](float spacing_mm) { return spacing_mm > 0 ? 10 / spacing_mm : 0.0f; };
  const auto unless_given = [](float& value, float from_scan) {
    if (value == 0) value = from_scan;
  };
  unless_given(given.wales_per_cm, per_cm(wale_mm));
  unless_given(given.courses_per_cm, per_cm(course_mm));
  unless_given(given.ends_per_cm, per_cm(end_mm));
  unless_given(given.picks_per_cm, per_cm(pick_mm));
  if (knitted && knit) unless_given(given.yarn_mm, knit->chart.gauge.yarn_diameter_mm);
  return given;
}

std::string ScanCloth::describe() const {
  if (knit)
    return fmt::format("chart {} x {} read off {} ({} colour{}, {:.1f} % of {} stitches agree), "
                       "shear {:.2f}",
                       knit->chart.columns, knit->chart.rows, maps.string(),
                       knit->chart.palette.size(), knit->chart.palette.size() == 1 ? "" : "s",
                       100 * knit->agreement, knit->columns * knit->rows, shear);
  return fmt::format("the gauge and shear {:.2f} of {}", shear, maps.string());
}

Result<ScanCloth> scan_cloth_of(const formats::Maps& maps, std::vector<std::string> warnings) {
  ScanCloth out;
  out.maps = maps.directory;
  const cv::Scalar mean = cv::mean(maps.albedo);
  out.mean_colour = {static_cast<float>(mean[2]), static_cast<float>(mean[1]),
                     static_cast<float>(mean[0])};
  auto fabric = analysis::fabric_of_maps(maps, warnings);
  if (!fabric) return std::unexpected(fabric.error());
  out.fabric = std::move(*fabric);
  const double mm = maps.pixel_size_mm.value_or(0);
  const bool woven = out.fabric.construction == analysis::Construction::woven;
  if (out.fabric.periodic) {
    // The repeat's densities and skew, for when no chart can be read.
    out.shear = static_cast<float>(-std::tan(out.fabric.skew_deg / kDeg));
    const double lean = std::hypot(1.0, static_cast<double>(out.shear));
    if (mm > 0 && out.fabric.across_density > 0 && out.fabric.along_density > 0) {
      const auto across = static_cast<float>(10 / out.fabric.across_density * lean);
      const auto along = static_cast<float>(10 / out.fabric.along_density);
      (woven ? out.end_mm : out.wale_mm) = across;
      (woven ? out.pick_mm : out.course_mm) = along;
    }
  }
  auto knit = analysis::infer_knit_chart(maps, out.fabric);
  if (knit) {
    rest_shape(knit->lattice.next_wale_px, knit->lattice.next_course_px, mm, out, true);
    if (!(mm > 0)) out.wale_mm = out.course_mm = 0;
    out.knit = std::move(*knit);
  } else {
    out.why = knit.error().message;
  }
  out.warnings = std::move(warnings);
  return out;
}

Result<ScanCloth> read_scan_cloth(const std::filesystem::path& directory) {
  std::vector<std::string> warnings;
  auto maps = formats::read_maps(directory, warnings);
  if (!maps) return std::unexpected(maps.error());
  return scan_cloth_of(*maps, std::move(warnings));
}

}  // namespace psrig::preview
