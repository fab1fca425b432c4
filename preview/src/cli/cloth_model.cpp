#include "cloth_model.h"

namespace psrig::preview::cli {

Result<ClothModel> ClothModel::load(const std::filesystem::path& pattern, int columns, int rows,
                                    std::optional<Eigen::Vector3f> colour, ClothShape shape) {
  if (looks_like_weave(pattern)) {
    auto weave = load_weave_matrix(pattern);
    if (!weave) return std::unexpected(weave.error());
    Woven woven{std::move(*weave), {}, columns, rows};
    woven.parameters.shape = shape;
    if (colour) woven.parameters.style.colour = *colour;
    return ClothModel(std::move(woven));
  }
  auto chart = load_stitch_chart(pattern);
  if (!chart) return std::unexpected(chart.error());
  KnitLayout layout = tile_chart(*chart, columns, rows);
  KnitParameters parameters;
  parameters.shape = shape;
  if (colour) {
    layout.colours.clear();
    parameters.style.colour = *colour;
  }
  return ClothModel(KnitFabric::build(layout, parameters));
}

void ClothModel::update(ClothDeformation deformation, YarnSet& yarns) {
  if (auto* knit = std::get_if<KnitFabric>(&cloth_)) {
    knit->update(knit->mesh(deformation), yarns);
    return;
  }
  Woven& woven = std::get<Woven>(cloth_);
  weave_yarns(woven.weave, woven_mesh(woven.warps, woven.wefts, woven.parameters, deformation),
              woven.parameters, yarns);
}

}  // namespace psrig::preview::cli
