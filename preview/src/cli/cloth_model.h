#pragma once
// The cloth `psrig-preview knit` draws: a stitch chart as knitted yarns or a
// weave matrix as woven threads, either one deformed on demand.

#include <filesystem>
#include <optional>
#include <variant>

#include "psrig/preview/knit_fabric.h"
#include "psrig/preview/weave_matrix.h"
#include "psrig/preview/woven_fabric.h"

namespace psrig::preview::cli {

class ClothModel {
 public:
  // columns x rows stitches (or warps x wefts) on `shape`; `colour`, when
  // given, replaces the chart's palette and the style's colour.
  [[nodiscard]] static Result<ClothModel> load(const std::filesystem::path& pattern, int columns,
                                               int rows, std::optional<Eigen::Vector3f> colour,
                                               ClothShape shape = ClothShape::flat);

  // This deformation's yarns into `yarns` (storage reused).
  void update(ClothDeformation deformation, YarnSet& yarns);
  [[nodiscard]] bool woven() const { return std::holds_alternative<Woven>(cloth_); }

 private:
  struct Woven {
    WeaveMatrix weave;
    WovenParameters parameters;
    int warps = 0, wefts = 0;
  };
  std::variant<KnitFabric, Woven> cloth_;

  explicit ClothModel(std::variant<KnitFabric, Woven> cloth) : cloth_(std::move(cloth)) {}
};

}  // namespace psrig::preview::cli
