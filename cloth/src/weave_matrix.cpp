#include "psrig/cloth/weave_matrix.h"

#include <algorithm>
#include <cctype>
#include <optional>

#include "pattern_text.h"

namespace psrig::cloth {

namespace fs = std::filesystem;
using pattern_text::error_at;

bool WeaveMatrix::warp_over(int warp, int weft) const {
  return cells[static_cast<std::size_t>(pattern_text::wrap(weft, wefts) * warps +
                                        pattern_text::wrap(warp, warps))] != 0;
}

Result<WeaveMatrix> parse_weave_matrix(std::string_view text, const fs::path& source) {
  WeaveMatrix matrix;
  std::optional<std::string> name;
  int first_row_line = 0;
  for (const pattern_text::Line& line : pattern_text::split_lines(text)) {
    const std::string_view code = pattern_text::trim(pattern_text::strip_comment(line.text));
    if (code.empty()) continue;
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
                "': lines are rows of 1 (warp over weft) and 0 (weft over warp), `name: ...` "
                "or # comments"));
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
