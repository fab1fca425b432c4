#pragma once
// The cloth `psrig-preview knit` draws: a stitch chart as knitted yarns or a
// weave matrix as woven threads, at the gauge the file or the command line
// gives, either one deformed on demand.

#include <filesystem>
#include <optional>
#include <variant>

#include "psrig/cloth/knit_fabric.h"
#include "psrig/cloth/weave_matrix.h"
#include "psrig/cloth/woven_fabric.h"

namespace psrig::preview {

// Sizes given on the command line, over the pattern file's; 0: not given.
struct ClothSize {
  float wales_per_cm = 0, courses_per_cm = 0;  // knits
  float ends_per_cm = 0, picks_per_cm = 0;     // wovens
  float yarn_mm = 0;
};

class ClothModel {
 public:
  // columns x rows stitches (or warps x wefts) on `shape`; `colour`, when
  // given, replaces the chart's palette and the style's colour.
  [[nodiscard]] static Result<ClothModel> load(const std::filesystem::path& pattern, int columns,
                                               int rows, std::optional<Eigen::Vector3f> colour,
                                               cloth::ClothShape shape = cloth::ClothShape::flat,
                                               const ClothSize& size = {});
  // A chart at hand (one read off a scan): `colour` as load's;
  // `stitch_colours`, when not empty, one linear RGB per stitch (row-major,
  // row 0 first) over both.
  [[nodiscard]] static Result<ClothModel> knit(cloth::StitchChart chart, int columns, int rows,
                                               std::optional<Eigen::Vector3f> colour,
                                               std::vector<Eigen::Vector3f> stitch_colours,
                                               cloth::ClothShape shape, const ClothSize& size);

  // This deformation's yarns into `yarns` (storage reused).
  void update(cloth::ClothDeformation deformation, cloth::YarnSet& yarns);
  [[nodiscard]] bool woven() const { return std::holds_alternative<cloth::WovenFabric>(cloth_); }
  // The weave and its yarns' colours (the neural far level's material), or none.
  [[nodiscard]] const cloth::WovenFabric* woven_fabric() const {
    return std::get_if<cloth::WovenFabric>(&cloth_);
  }
  // What it is, in a few words: gauge or density and yarn.
  [[nodiscard]] std::string describe() const;

 private:
  std::variant<cloth::KnitFabric, cloth::WovenFabric> cloth_;

  explicit ClothModel(std::variant<cloth::KnitFabric, cloth::WovenFabric> cloth)
      : cloth_(std::move(cloth)) {}
};

}  // namespace psrig::preview
