#include "psrig/preview/cloth_model.h"

#include <spdlog/fmt/fmt.h>

namespace psrig::preview {
namespace {

// A gauge or yarn error names the pattern file.
Error naming(Error error, const std::filesystem::path& pattern) {
  if (error.file.empty()) error.file = pattern;
  return error;
}

}  // namespace

Result<ClothModel> ClothModel::load(const std::filesystem::path& pattern, int columns, int rows,
                                    std::optional<Eigen::Vector3f> colour, cloth::ClothShape shape,
                                    const ClothSize& size) {
  if (cloth::looks_like_weave(pattern)) {
    auto weave = cloth::load_weave_matrix(pattern);
    if (!weave) return std::unexpected(weave.error());
    cloth::WovenParameters parameters;
    parameters.shape = shape;
    parameters.gauge = {size.ends_per_cm, size.picks_per_cm, size.yarn_mm};
    if (colour) parameters.warp_colour = *colour;
    auto woven = cloth::WovenFabric::build(*weave, columns, rows, parameters);
    if (!woven) return std::unexpected(naming(woven.error(), pattern));
    return ClothModel(std::move(*woven));
  }
  auto chart = cloth::load_stitch_chart(pattern);
  if (!chart) return std::unexpected(chart.error());
  auto knitted = knit(std::move(*chart), columns, rows, colour, {}, shape, size);
  if (!knitted) return std::unexpected(naming(knitted.error(), pattern));
  return knitted;
}

Result<ClothModel> ClothModel::knit(cloth::StitchChart chart, int columns, int rows,
                                    std::optional<Eigen::Vector3f> colour,
                                    std::vector<Eigen::Vector3f> stitch_colours,
                                    cloth::ClothShape shape, const ClothSize& size) {
  cloth::KnitParameters parameters;
  parameters.shape = shape;
  parameters.gauge = {size.wales_per_cm, size.courses_per_cm, size.yarn_mm};
  if (colour) {
    chart.palette.clear();
    parameters.colour = *colour;
  }
  auto fabric =
      cloth::KnitFabric::build(chart, columns, rows, parameters, std::move(stitch_colours));
  if (!fabric) return std::unexpected(fabric.error());
  return ClothModel(std::move(*fabric));
}

void ClothModel::update(cloth::ClothDeformation deformation, cloth::YarnSet& yarns) {
  std::visit([&](auto& fabric) { fabric.update(fabric.mesh(deformation), yarns); }, cloth_);
}

std::string ClothModel::describe() const {
  if (const auto* knit = std::get_if<cloth::KnitFabric>(&cloth_)) {
    const cloth::KnitRepeatLayout& repeat = knit->repeat();
    return fmt::format("{:.1f} wales x {:.1f} courses per cm, yarn {:.2f} mm",
                       10 * static_cast<float>(knit->chart().columns) / repeat.width_mm,
                       10 * static_cast<float>(knit->chart().rows) / repeat.height_mm,
                       knit->dimensions().yarn_diameter_mm);
  }
  const auto& woven = std::get<cloth::WovenFabric>(cloth_);
  return fmt::format("{:.1f} ends x {:.1f} picks per cm, yarn {:.2f} mm",
                     10 / woven.dimensions().end_spacing_mm, 10 / woven.dimensions().pick_spacing_mm,
                     woven.dimensions().yarn_diameter_mm);
}

}  // namespace psrig::preview
