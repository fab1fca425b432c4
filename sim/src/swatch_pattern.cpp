#include "psrig/sim/swatch_pattern.h"

#include <algorithm>
#include <array>
#include <system_error>
#include <type_traits>
#include <utility>

#include "psrig/cloth/knit_fabric.h"
#include "psrig/cloth/woven_fabric.h"

namespace psrig::sim {
namespace {

namespace fs = std::filesystem;

// The simulator's names before the patterns were files, kept so that older
// rig.toml files, scans and scripts go on working.
constexpr std::array<std::pair<std::string_view, std::string_view>, 5> kAliases{{
    {"jersey", "stockinette"},
    {"rib", "rib-1x1"},
    {"garter", "garter"},
    {"plain", "plain"},
    {"twill", "twill-2x2"},
}};

std::string_view unalias(std::string_view name) {
  for (const auto& [alias, shipped] : kAliases)
    if (alias == name) return shipped;
  return name;
}

// The smallest n dividing `count` with same(i, i + n) for every i: the
// pattern's own period when its file writes it out more than once.
template <class Same>
int smallest_period(int count, Same same) {
  for (int n = 1; n < count; ++n) {
    if (count % n != 0) continue;
    bool repeats = true;
    for (int i = 0; i < count && repeats; ++i)
      repeats = same(i, i + n);
    if (repeats) return n;
  }
  return count;
}

Result<SwatchGauge> knit_gauge_of(const cloth::StitchChart& chart) {
  // The cloth's own layout (draw-in, the chart's gauge), as the swatch is built.
  auto fabric = cloth::KnitFabric::build(chart, chart.columns, chart.rows, {});
  if (!fabric) return std::unexpected(fabric.error());
  const cloth::KnitRepeatLayout& repeat = fabric->repeat();
  const auto same = [&](int c0, int r0, int c1, int r1) {
    return chart.at(c0, r0) == chart.at(c1, r1) &&
           chart.colour_at(c0, r0) == chart.colour_at(c1, r1);
  };
  SwatchGauge gauge;
  gauge.knitted = true;
  gauge.across_per_cm = 10.0 * chart.columns / repeat.width_mm;
  gauge.along_per_cm = 10.0 * chart.rows / repeat.height_mm;
  gauge.across_per_repeat = smallest_period(chart.columns, [&](int i, int j) {
    for (int row = 0; row < chart.rows; ++row)
      if (!same(i, row, j, row)) return false;
    return true;
  });
  gauge.along_per_repeat = smallest_period(chart.rows, [&](int i, int j) {
    for (int column = 0; column < chart.columns; ++column)
      if (!same(column, i, column, j)) return false;
    return true;
  });
  return gauge;
}

Result<SwatchGauge> woven_gauge_of(const cloth::WeaveMatrix& weave) {
  auto fabric = cloth::WovenFabric::build(weave, weave.warps, weave.wefts, {});
  if (!fabric) return std::unexpected(fabric.error());
  SwatchGauge gauge;
  gauge.knitted = false;
  gauge.across_per_cm = 10.0 / fabric->dimensions().end_spacing_mm;
  gauge.along_per_cm = 10.0 / fabric->dimensions().pick_spacing_mm;
  gauge.across_per_repeat = smallest_period(weave.warps, [&](int i, int j) {
    for (int weft = 0; weft < weave.wefts; ++weft)
      if (weave.warp_over(i, weft) != weave.warp_over(j, weft)) return false;
    return true;
  });
  gauge.along_per_repeat = smallest_period(weave.wefts, [&](int i, int j) {
    for (int warp = 0; warp < weave.warps; ++warp)
      if (weave.warp_over(warp, i) != weave.warp_over(warp, j)) return false;
    return true;
  });
  return gauge;
}

std::string names_list() {
  std::string list;
  for (const std::string& name : shipped_pattern_names())
    list += (list.empty() ? "" : ", ") + name;
  return list;
}

fs::path own_folder() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path() : self.parent_path();
}

bool looks_like_file(std::string_view text) {
  const fs::path path(text);
  return text.find('/') != std::string_view::npos || path.extension() == ".chart" ||
         path.extension() == ".weave";
}

}  // namespace

Result<SwatchPattern> swatch_pattern(std::variant<cloth::StitchChart, cloth::WeaveMatrix> cloth,
                                     std::string name, fs::path file) {
  auto gauge = std::visit(
      [](const auto& pattern) -> Result<SwatchGauge> {
        if constexpr (std::is_same_v<std::decay_t<decltype(pattern)>, cloth::StitchChart>)
          return knit_gauge_of(pattern);
        else
          return woven_gauge_of(pattern);
      },
      cloth);
  if (!gauge) {
    Error error = std::move(gauge.error());
    if (error.file.empty()) error.file = file;
    return std::unexpected(std::move(error));
  }
  return SwatchPattern{std::move(name), std::move(file), std::move(cloth), *gauge};
}

const std::vector<std::string>& shipped_pattern_names() {
  static const std::vector<std::string> names{"stockinette", "garter",      "rib-1x1", "rib-2x2",
                                              "seed",        "basketweave", "stripes", "plain",
                                              "twill-2x2",   "satin-5"};
  return names;
}

fs::path find_patterns_dir(const fs::path& configured) {
  if (!configured.empty()) return configured;
  std::error_code ec;
  if (const fs::path folder = own_folder(); !folder.empty()) {
    const fs::path installed = folder / ".." / "share" / "psrig" / "patterns";
    if (fs::is_directory(installed, ec)) return fs::weakly_canonical(installed, ec);
  }
  if (const fs::path source(PSRIG_SOURCE_PATTERNS_DIR); fs::is_directory(source, ec)) return source;
  return {};
}

Result<SwatchPattern> load_swatch_pattern(std::string_view path_or_name,
                                          const fs::path& patterns_dir, const fs::path& relative_to,
                                          std::string_view key) {
  const std::string given(path_or_name);
  fs::path file;
  std::string name;
  if (looks_like_file(given)) {
    file = relative_to.empty() || fs::path(given).is_absolute() ? fs::path(given)
                                                                : relative_to / given;
  } else {
    const std::string_view shipped = unalias(given);
    const bool known =
        std::ranges::find(shipped_pattern_names(), shipped) != shipped_pattern_names().end();
    const fs::path folder = find_patterns_dir(patterns_dir);
    std::error_code ec;
    if (folder.empty() || !fs::is_directory(folder, ec))
      return std::unexpected(bad_input(
          patterns_dir, std::string(key),
          "the shipped patterns are not found (" +
              (patterns_dir.empty() ? std::string("not installed in share/psrig/patterns")
                                    : "\"" + patterns_dir.string() + "\" is not a folder") +
              "); give a .chart or .weave file, or point [sim] patterns_dir at config/patterns"));
    for (const char* extension : {".chart", ".weave"}) {
      const fs::path candidate = folder / (std::string(shipped) + extension);
      if (fs::is_regular_file(candidate, ec)) file = candidate;
    }
    if (file.empty())
      return std::unexpected(
          bad_input({}, std::string(key),
                    "\"" + given + "\" is neither a .chart or .weave file nor a shipped pattern" +
                        (known ? " (it should be in " + folder.string() + ")" : "") +
                        "; give a file or one of " + names_list() + " (or jersey, rib, twill)"));
    name = given;
  }
  std::error_code ec;
  if (!fs::is_regular_file(file, ec))
    return std::unexpected(
        bad_input(file, std::string(key),
                  "no such pattern file; give a .chart or .weave file or one of " + names_list()));
  std::variant<cloth::StitchChart, cloth::WeaveMatrix> cloth;
  if (cloth::looks_like_weave(file)) {
    auto weave = cloth::load_weave_matrix(file);
    if (!weave) return std::unexpected(weave.error());
    cloth = std::move(*weave);
  } else {
    auto chart = cloth::load_stitch_chart(file);
    if (!chart) return std::unexpected(chart.error());
    cloth = std::move(*chart);
  }
  if (name.empty()) name = std::visit([](const auto& pattern) { return pattern.name; }, cloth);
  return swatch_pattern(std::move(cloth), std::move(name), file);
}

}  // namespace psrig::sim
