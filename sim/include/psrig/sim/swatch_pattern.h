#pragma once
// What the simulated swatch is made of: a knitting stitch chart (.chart) or
// a weave matrix (.weave), the same files `psrig-preview knit` draws
// (config/patterns/README.md), given by path or by a shipped pattern's name,
// and the gauge the cloth built from it has: the truth `psrig measure` is
// tested against.

#include <filesystem>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "psrig/base/error.h"
#include "psrig/cloth/stitch_chart.h"
#include "psrig/cloth/weave_matrix.h"

namespace psrig::sim {

// The cloth's gauge as made, from its repeat: a knit's wales and courses per
// cm (10 x the repeat's columns over its width in mm, draw-in included), a
// woven's ends and picks per cm; and how many of each one repeat of the
// pattern (stitches and colours) holds.
struct SwatchGauge {
  bool knitted = true;
  double across_per_cm = 0;  // wales or ends: threads met going across the image
  double along_per_cm = 0;   // courses or picks: going up it
  int across_per_repeat = 1;
  int along_per_repeat = 1;
};

struct SwatchPattern {
  // The structure's name for scan.json: a shipped name or alias as given
  // ("jersey", "rib-1x1"), else the file's `name:` (or its stem).
  std::string name;
  std::filesystem::path file;  // where it was read from; empty when made in memory
  std::variant<cloth::StitchChart, cloth::WeaveMatrix> cloth;
  SwatchGauge gauge;

  [[nodiscard]] bool knitted() const { return std::holds_alternative<cloth::StitchChart>(cloth); }
};

// A chart or weave (already parsed) as a swatch pattern; bad input when no
// cloth can be made of it at its gauge (cloth/knit_gauge.h, woven_cell.h).
[[nodiscard]] Result<SwatchPattern> swatch_pattern(
    std::variant<cloth::StitchChart, cloth::WeaveMatrix> cloth, std::string name,
    std::filesystem::path file = {});

// The shipped patterns, by name: stockinette, garter, rib-1x1, rib-2x2,
// seed, basketweave, stripes (knitted), plain, twill-2x2, satin-5 (woven);
// the simulator's older names jersey, rib, garter, plain and twill are
// aliases of stockinette, rib-1x1, garter, plain and twill-2x2.
[[nodiscard]] const std::vector<std::string>& shipped_pattern_names();

// Where the shipped patterns are: `configured` when not empty (rig.toml's
// [sim] patterns_dir), else the first of <program's folder>/../share/psrig/
// patterns (installed) and the source tree's config/patterns (the build's).
// Empty when none exists.
[[nodiscard]] std::filesystem::path find_patterns_dir(const std::filesystem::path& configured = {});

// `path_or_name`: a .chart or .weave file (relative to `relative_to` when
// given, else to the working directory), or a shipped pattern's name or
// alias found in find_patterns_dir(patterns_dir). Errors name `key` (the
// option or rig.toml key that gave it) and the fix.
[[nodiscard]] Result<SwatchPattern> load_swatch_pattern(
    std::string_view path_or_name, const std::filesystem::path& patterns_dir = {},
    const std::filesystem::path& relative_to = {}, std::string_view key = "pattern");

}  // namespace psrig::sim
