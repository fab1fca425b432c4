#pragma once
// The cloth `psrig-preview knit` draws: a stitch chart as knitted yarns or a
// weave matrix as woven threads, either one deformed on demand.

#include <filesystem>
#include <optional>
#include <variant>

#include "psrig/cloth/knit_fabric.h"
#include "psrig/cloth/weave_matrix.h"
#include "psrig/cloth/woven_fabric.h"

namespace psrig::preview::cli {

class ClothModel {
 public:
  // columns x rows stitches (or warps x wefts) on `shape`; `colour`, when
  // given, replaces the chart's palette and the style's colour.
  [[nodiscard]] static Result<ClothModel> load(const std::filesystem::path& pattern, int columns,
                                               int rows, std::optional<Eigen::Vector3f> colour,
                                               cloth::ClothShape shape = cloth::ClothShape::flat);

  // This deformation's yarns into `yarns` (storage reused).
  void update(cloth::ClothDeformation deformation, cloth::YarnSet& yarns);
  [[nodiscard]] bool woven() const { return std::holds_alternative<Woven>(cloth_); }

 private:
  struct Woven {
    cloth::WeaveMatrix weave;
    cloth::WovenParameters parameters;
    int warps = 0, wefts = 0;
  };
  std::variant<cloth::KnitFabric, Woven> cloth_;

  explicit ClothModel(std::variant<cloth::KnitFabric, Woven> cloth) : cloth_(std::move(cloth)) {}
};

}  // namespace psrig::preview::cli
