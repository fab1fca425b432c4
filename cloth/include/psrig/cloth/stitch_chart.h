#pragma once
// A knitting stitch chart: the repeat of knit and purl stitches (and,
// optionally, yarn colours) that the knit renderer tiles over the cloth.
// The text format is in config/patterns/README.md.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "psrig/base/error.h"
#include "psrig/cloth/knit_gauge.h"

namespace psrig::cloth {

// A stitch as seen from the fabric's front (right side): a knit loop shows
// as a V, a purl as a bump.
enum class Stitch : std::uint8_t { knit, purl };

// Row 0 is the bottom course, the first one knitted; columns count from the
// left as the front is seen.
struct StitchChart {
  std::string name;
  int columns = 0;
  int rows = 0;
  std::vector<Stitch> cells;               // row-major, columns * rows
  std::vector<std::uint8_t> colour_index;  // per cell, into palette; all 0 without colour rows
  std::vector<Eigen::Vector3f> palette;    // linear RGB; empty when the chart names no colours
  // The knit's size, where the chart gives it (`wales_per_cm:`,
  // `courses_per_cm:`, `yarn_mm:`); 0 where not.
  KnitGauge gauge;

  // The chart tiled over the plane: any column and row, negative included.
  [[nodiscard]] Stitch at(int column, int row) const;
  [[nodiscard]] int colour_at(int column, int row) const;
};

// `source` names the text in errors and gives the name when the chart has
// no `name:` line. Errors are bad input at the line and column concerned.
[[nodiscard]] Result<StitchChart> parse_stitch_chart(std::string_view text,
                                                     const std::filesystem::path& source);

// A .chart file; an io error when it cannot be read.
[[nodiscard]] Result<StitchChart> load_stitch_chart(const std::filesystem::path& file);

// The chart as .chart text that parse_stitch_chart() reads back: `comment`
// (each line a # comment) first, then its name, the gauge keys it gives,
// the palette as colour letters A, B, ... in sRGB hex, and the rows from
// row 0 (the bottom course) up, each with its colour row when the palette
// has two colours or more.
[[nodiscard]] std::string format_stitch_chart(const StitchChart& chart,
                                              std::string_view comment = {});

}  // namespace psrig::cloth
