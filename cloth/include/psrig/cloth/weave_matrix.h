#pragma once
// A weave's repeat as the weaver's draft gives it: for each crossing of a
// warp (a column) and a weft (a row), which yarn lies on top, seen from the
// cloth's front. The text format is in config/patterns/README.md.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <optional>

#include <Eigen/Core>

#include "psrig/base/error.h"
#include "psrig/cloth/woven_cell.h"

namespace psrig::cloth {

struct WeaveMatrix {
  std::string name;
  int warps = 0;                    // columns
  int wefts = 0;                    // rows; row 0 is the first weft woven
  std::vector<std::uint8_t> cells;  // row-major: 1 = warp over weft, 0 = weft over warp
  // The cloth's size and yarn colours where the file gives them
  // (`ends_per_cm:`, `picks_per_cm:`, `yarn_mm:`; `colour warp #RRGGBB`,
  // `colour weft #RRGGBB`, linear RGB here).
  WovenGauge gauge;
  std::optional<Eigen::Vector3f> warp_colour, weft_colour;
  // The fabric surface model's look where the file gives it (chen2024 3.1,
  // `roughness:` alpha within [0.1, 1] and `height_scale:` beta within
  // (0, 2], the ranges its neural BSDF was trained on); 0 where it does not.
  float roughness = 0, height_scale = 0;

  // The repeat tiled over the plane: any warp and weft, negative included.
  [[nodiscard]] bool warp_over(int warp, int weft) const;
};

// `source` names the text in errors and gives the name when the matrix has
// no `name:` line. Errors are bad input at the line and column concerned.
[[nodiscard]] Result<WeaveMatrix> parse_weave_matrix(std::string_view text,
                                                     const std::filesystem::path& source);

// A .weave file; an io error when it cannot be read.
[[nodiscard]] Result<WeaveMatrix> load_weave_matrix(const std::filesystem::path& file);

// Whether a pattern file is a weave (`.weave`) rather than a knit stitch
// chart (`.chart`), by its extension in any case.
[[nodiscard]] bool looks_like_weave(const std::filesystem::path& file);

}  // namespace psrig::cloth
