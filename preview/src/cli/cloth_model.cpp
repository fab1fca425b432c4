#include "cloth_model.h"

namespace psrig::preview::cli {

Result<ClothModel> ClothModel::load(const std::filesystem::path& pattern, int columns, int rows,
                                    std::optional<Eigen::Vector3f> colour, cloth::ClothShape shape) {
  if (cloth::looks_like_weave(pattern)) {
    auto weave = cloth::load_weave_matrix(pattern);
    if (!weave) return std::unexpected(weave.error());
    Woven woven{std::move(*weave), {}, columns, rows};
    woven.parameters.shape = shape;
    if (colour) woven.parameters.style.colour = *colour;
    return ClothModel(std::move(woven));
  }
  auto chart = cloth::load_stitch_chart(pattern);
  if (!chart) return std::unexpected(chart.error());
  cloth::KnitLayout layout = cloth::tile_chart(*chart, columns, rows);
  cloth::KnitParameters parameters;
  parameters.shape = shape;
  if (colour) {
    layout.colours.clear();
    parameters.style.colour = *colour;
  }
  return ClothModel(cloth::KnitFabric::build(layout, parameters));
}

void ClothModel::update(cloth::ClothDeformation deformation, cloth::YarnSet& yarns) {
  if (auto* knit = std::get_if<cloth::KnitFabric>(&cloth_)) {
    knit->update(knit->mesh(deformation), yarns);
    return;
  }
  Woven& woven = std::get<Woven>(cloth_);
  cloth::weave_yarns(woven.weave, cloth::woven_mesh(woven.warps, woven.wefts, woven.parameters, deformation),
              woven.parameters, yarns);
}

}  // namespace psrig::preview::cli
