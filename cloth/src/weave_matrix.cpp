#include "psrig/cloth/weave_matrix.h"

#include <algorithm>
#include <cctype>
#include <optional>

#include "pattern_text.h"
#include "psrig/cloth/srgb.h"

namespace psrig::cloth {

namespace fs = std::filesystem;
using pattern_text::error_at;

bool WeaveMatrix::warp_over(int warp, int weft) const {
  return cells[static_cast<std::size_t>(pattern_text::wrap(weft, wefts) * warps +
                                        pattern_text::wrap(warp, warps))] != 0;
}

namespace {

// `colour warp #RRGGBB` or `colour weft #RRGGBB`; the `#` of the value is
// not a comment.
Status read_thread_colour(const fs::path& source, const pattern_text::Line& line,
                          std::string_view rest, WeaveMatrix& matrix) {
  rest = pattern_text::trim(rest);
  std::size_t end = 0;
  while (end < rest.size() && !pattern_text::is_space(rest[end]))
    ++end;
  const std::string_view thread = rest.substr(0, end);
  if (thread != "warp" && thread != "weft")
    return std::unexpected(error_at(source, line.number, line.column_of(rest),
                                    "a weave's colours are `colour warp #RRGGBB` and `colour weft "
                                    "#RRGGBB`"));
  std::optional<Eigen::Vector3f>& slot = thread == "warp" ? matrix.warp_colour : matrix.weft_colour;
  if (slot)
    return std::unexpected(error_at(source, line.number, line.column_of(rest),
                                    "a second colour for the " + std::string(thread)));
  std::string_view value = pattern_text::trim(rest.substr(end));
  std::size_t value_end = 0;
  while (value_end < value.size() && !pattern_text::is_space(value[value_end]))
    ++value_end;
  const std::string_view hex = value.substr(0, value_end);
  const std::optional<Eigen::Vector3f> colour = parse_srgb_hex(hex);
  if (!colour)
    return std::unexpected(error_at(source, line.number,
                                    line.column_of(hex.empty() ? rest : hex),
                                    "malformed colour '" + std::string(hex) +
                                        "': expected #RRGGBB (sRGB, hexadecimal)"));
  const std::string_view after = pattern_text::trim(value.substr(value_end));
  if (!after.empty() && after.front() != '#')
    return std::unexpected(error_at(source, line.number, line.column_of(after),
                                    "unexpected '" + std::string(after) +
                                        "' after the colour (comments start with #)"));
  slot = *colour;
  return {};
}

// The look's keys within the ranges chen2024's network was trained on
// (woven_dataset_generator.cpp draws alpha from [0.1, 1], beta from
// [0, 2]): outside them its far level would be a guess.
Status look_within_training(const fs::path& source, const pattern_text::Line& line,
                            const pattern_text::KeyValue& entry, const WeaveMatrix& matrix) {
  const auto outside = [&](const char* range, const char* what) -> Status {
    return std::unexpected(error_at(source, line.number, line.column_of(entry.value),
                                    std::string(entry.key) + " must be within " + range + " (" +
                                        what + "), not " + std::string(entry.value)));
  };
  if (entry.key == "roughness" && !(matrix.roughness >= 0.1f && matrix.roughness <= 1))
    return outside("0.1 to 1", "the yarns' microflake roughness, chen2024's alpha");
  if (entry.key == "height_scale" && !(matrix.height_scale <= 2))
    return outside("0 to 2",
                   "how far the yarns' relief is scaled, chen2024's beta");
  return {};
}

}  // namespace

Result<WeaveMatrix> parse_weave_matrix(std::string_view text, const fs::path& source) {
  WeaveMatrix matrix;
  std::optional<std::string> name;
  int first_row_line = 0;
  for (const pattern_text::Line& line : pattern_text::split_lines(text)) {
    const std::string_view whole = pattern_text::trim(line.text);
    bool colour_line = false;
    for (const std::string_view keyword : {"colour", "color"})
      if (whole.starts_with(keyword) && whole.size() > keyword.size() &&
          pattern_text::is_space(whole[keyword.size()])) {
        auto read = read_thread_colour(source, line, whole.substr(keyword.size()), matrix);
        if (!read) return std::unexpected(read.error());
        colour_line = true;
      }
    if (colour_line) continue;
    const std::string_view code = pattern_text::trim(pattern_text::strip_comment(line.text));
    if (code.empty()) continue;
    if (const auto entry = pattern_text::key_value(code)) {
      auto read = pattern_text::read_measure(source, line, *entry,
                                             {{"ends_per_cm", &matrix.gauge.ends_per_cm},
                                              {"picks_per_cm", &matrix.gauge.picks_per_cm},
                                              {"yarn_mm", &matrix.gauge.yarn_diameter_mm},
                                              {"roughness", &matrix.roughness},
                                              {"height_scale", &matrix.height_scale}});
      if (!read) return std::unexpected(read.error());
      auto within = look_within_training(source, line, *entry, matrix);
      if (!within) return std::unexpected(within.error());
      continue;
    }
    if (const auto value = pattern_text::name_value(code)) {
      if (name)
        return std::unexpected(
            error_at(source, line.number, line.column_of(code), "a second `name:` line"));
      name = std::string(*value);
      continue;
    }
    int width = 0;
    for (std::size_t i = 0; i < code.size(); ++i) {
      const char c = code[i];
      if (pattern_text::is_space(c)) continue;
      if (c != '0' && c != '1')
        return std::unexpected(error_at(
            source, line.number, line.column_of(code.substr(i)),
            std::string("unknown symbol '") + c +
                "': lines are rows of 1 (warp over weft) and 0 (weft over warp), `name: ...`, "
                "`ends_per_cm: N`, `picks_per_cm: N`, `yarn_mm: D`, `roughness: A`, "
                "`height_scale: B`, `colour warp #RRGGBB`, `colour weft #RRGGBB` or # comments"));
      matrix.cells.push_back(c == '1' ? 1 : 0);
      ++width;
    }
    if (matrix.wefts == 0) {
      matrix.warps = width;
      first_row_line = line.number;
    } else if (width != matrix.warps) {
      return std::unexpected(error_at(
          source, line.number, line.column_of(code),
          "row " + std::to_string(matrix.wefts) + " has " + std::to_string(width) +
              " crossings, expected " + std::to_string(matrix.warps) + " like row 0 (line " +
              std::to_string(first_row_line) + "); rows count from 0, the first weft"));
    }
    ++matrix.wefts;
  }
  if (matrix.wefts == 0)
    return std::unexpected(
        bad_input(source, {}, "the weave has no rows (lines of 0 and 1, the first weft first)"));
  matrix.name = name && !name->empty() ? *name : source.stem().string();
  return matrix;
}

Result<WeaveMatrix> load_weave_matrix(const fs::path& file) {
  auto text = pattern_text::read_text_file(file);
  if (!text) return std::unexpected(text.error());
  return parse_weave_matrix(*text, file);
}

bool looks_like_weave(const fs::path& file) {
  std::string extension = file.extension().string();
  std::ranges::transform(extension, extension.begin(),
                         [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension == ".weave";
}

}  // namespace psrig::cloth
