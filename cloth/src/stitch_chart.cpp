#include "psrig/cloth/stitch_chart.h"

#include <algorithm>
#include <cctype>
#include <optional>

#include <spdlog/fmt/fmt.h>

#include "pattern_text.h"
#include "psrig/cloth/srgb.h"

namespace psrig::cloth {
namespace {

namespace fs = std::filesystem;
using pattern_text::error_at;
using pattern_text::Line;

constexpr const char* kLineKinds =
    "lines are stitch rows of K and P, `= colour letters`, `colour A #RRGGBB`, `name: ...`, "
    "`wales_per_cm: N`, `courses_per_cm: N`, `yarn_mm: D` or # comments";

struct Symbol {
  char letter = 0;
  int column = 0;  // 1-based, for errors
};

struct ColourRow {
  int line = 0;
  std::vector<Symbol> symbols;
};

struct StitchRow {
  int line = 0;
  std::vector<Stitch> stitches;
  std::optional<ColourRow> colours;
};

struct PaletteEntry {
  char letter = 0;
  int line = 0;
  Eigen::Vector3f linear;
};

// What a chart's lines say, before the colour letters are looked up (a
// palette line may come after the rows that use it).
struct ChartLines {
  std::optional<std::string> name;
  KnitGauge gauge;
  std::vector<StitchRow> rows;
  std::vector<PaletteEntry> palette;
};

std::vector<Symbol> symbols_of(const Line& line, std::string_view code) {
  std::vector<Symbol> symbols;
  for (std::size_t i = 0; i < code.size(); ++i)
    if (!pattern_text::is_space(code[i]))
      symbols.push_back({code[i], line.column_of(code.substr(i))});
  return symbols;
}

// `colour A #RRGGBB`: the `#` of the value is not a comment, so this line
// is read before comments are stripped.
Status read_palette_line(const fs::path& source, const Line& line, std::string_view rest,
                         ChartLines& chart) {
  rest = pattern_text::trim(rest);
  if (rest.empty() || rest.front() == '#')
    return std::unexpected(error_at(source, line.number, line.column_of(rest),
                                    "expected a colour letter and its sRGB value, e.g. "
                                    "`colour A #1F3A5F`"));
  const char letter = rest.front();
  if (!std::isalnum(static_cast<unsigned char>(letter)) ||
      (rest.size() > 1 && !pattern_text::is_space(rest[1])))
    return std::unexpected(
        error_at(source, line.number, line.column_of(rest),
                 "a colour's letter is one letter or digit, e.g. `colour A #1F3A5F`"));
  for (const PaletteEntry& entry : chart.palette)
    if (entry.letter == letter)
      return std::unexpected(error_at(source, line.number, line.column_of(rest),
                                      std::string("colour '") + letter +
                                          "' is already given on line " +
                                          std::to_string(entry.line)));

  std::string_view value = pattern_text::trim(rest.substr(1));
  std::size_t end = 0;
  while (end < value.size() && !pattern_text::is_space(value[end]))
    ++end;
  const std::string_view hex = value.substr(0, end);
  if (hex.empty())
    return std::unexpected(error_at(
        source, line.number, line.column_of(rest),
        std::string("colour '") + letter + "' has no value: expected #RRGGBB (sRGB, hexadecimal)"));
  const std::optional<Eigen::Vector3f> colour = parse_srgb_hex(hex);
  if (!colour)
    return std::unexpected(error_at(
        source, line.number, line.column_of(hex),
        "malformed colour '" + std::string(hex) + "': expected #RRGGBB (sRGB, hexadecimal)"));
  const std::string_view after = pattern_text::trim(value.substr(end));
  if (!after.empty() && after.front() != '#')
    return std::unexpected(error_at(
        source, line.number, line.column_of(after),
        "unexpected '" + std::string(after) + "' after the colour (comments start with #)"));
  chart.palette.push_back({letter, line.number, *colour});
  return {};
}

Status read_colour_row(const fs::path& source, const Line& line, std::string_view code,
                       ChartLines& chart) {
  if (chart.rows.empty())
    return std::unexpected(error_at(
        source, line.number, line.column_of(code),
        "a colour row (=) gives the colours of the stitch row before it, and there is none"));
  StitchRow& row = chart.rows.back();
  if (row.colours)
    return std::unexpected(error_at(source, line.number, line.column_of(code),
                                    "the stitch row on line " + std::to_string(row.line) +
                                        " already has a colour row (line " +
                                        std::to_string(row.colours->line) + ")"));
  ColourRow colours{line.number, symbols_of(line, code.substr(1))};
  if (colours.symbols.size() != row.stitches.size())
    return std::unexpected(error_at(source, line.number, line.column_of(code),
                                    "the colour row has " + std::to_string(colours.symbols.size()) +
                                        " letters, its stitch row (line " +
                                        std::to_string(row.line) + ") has " +
                                        std::to_string(row.stitches.size()) + " stitches"));
  row.colours = std::move(colours);
  return {};
}

Status read_stitch_row(const fs::path& source, const Line& line, std::string_view code,
                       ChartLines& chart) {
  StitchRow row{line.number, {}, std::nullopt};
  for (const Symbol& symbol : symbols_of(line, code)) {
    const char upper = static_cast<char>(std::toupper(static_cast<unsigned char>(symbol.letter)));
    if (upper != 'K' && upper != 'P')
      return std::unexpected(
          error_at(source, line.number, symbol.column,
                   std::string("unknown symbol '") + symbol.letter + "': " + kLineKinds));
    row.stitches.push_back(upper == 'K' ? Stitch::knit : Stitch::purl);
  }
  if (!chart.rows.empty() && row.stitches.size() != chart.rows.front().stitches.size())
    return std::unexpected(error_at(
        source, line.number, line.column_of(code),
        "row " + std::to_string(chart.rows.size()) + " has " + std::to_string(row.stitches.size()) +
            " stitches, expected " + std::to_string(chart.rows.front().stitches.size()) +
            " like row 0 (line " + std::to_string(chart.rows.front().line) +
            "); rows count from 0 at the bottom"));
  chart.rows.push_back(std::move(row));
  return {};
}

Status read_line(const fs::path& source, const Line& line, ChartLines& chart) {
  const std::string_view whole = pattern_text::trim(line.text);
  for (const std::string_view keyword : {"colour", "color"})
    if (whole.starts_with(keyword) && whole.size() > keyword.size() &&
        pattern_text::is_space(whole[keyword.size()]))
      return read_palette_line(source, line, whole.substr(keyword.size()), chart);

  const std::string_view code = pattern_text::trim(pattern_text::strip_comment(line.text));
  if (code.empty()) return {};
  if (const auto name = pattern_text::name_value(code)) {
    if (chart.name)
      return std::unexpected(
          error_at(source, line.number, line.column_of(code), "a second `name:` line"));
    chart.name = std::string(*name);
    return {};
  }
  if (const auto entry = pattern_text::key_value(code))
    return pattern_text::read_measure(source, line, *entry,
                                      {{"wales_per_cm", &chart.gauge.wales_per_cm},
                                       {"courses_per_cm", &chart.gauge.courses_per_cm},
                                       {"yarn_mm", &chart.gauge.yarn_diameter_mm}});
  if (code.front() == '=') return read_colour_row(source, line, code, chart);
  return read_stitch_row(source, line, code, chart);
}

std::string palette_letters(const std::vector<PaletteEntry>& palette) {
  if (palette.empty()) return "the chart has no `colour` lines";
  std::string letters = "the palette has ";
  for (std::size_t i = 0; i < palette.size(); ++i)
    letters += (i > 0 ? ", " : "") + std::string(1, palette[i].letter);
  return letters;
}

}  // namespace

Stitch StitchChart::at(int column, int row) const {
  return cells[static_cast<std::size_t>(pattern_text::wrap(row, rows) * columns +
                                        pattern_text::wrap(column, columns))];
}

int StitchChart::colour_at(int column, int row) const {
  return colour_index[static_cast<std::size_t>(pattern_text::wrap(row, rows) * columns +
                                               pattern_text::wrap(column, columns))];
}

Result<StitchChart> parse_stitch_chart(std::string_view text, const fs::path& source) {
  ChartLines lines;
  for (const Line& line : pattern_text::split_lines(text))
    if (auto read = read_line(source, line, lines); !read) return std::unexpected(read.error());
  if (lines.rows.empty())
    return std::unexpected(bad_input(
        source, {}, "the chart has no stitch rows (lines of K and P, the bottom course first)"));

  StitchChart chart;
  chart.name = lines.name && !lines.name->empty() ? *lines.name : source.stem().string();
  chart.columns = static_cast<int>(lines.rows.front().stitches.size());
  chart.rows = static_cast<int>(lines.rows.size());
  chart.gauge = lines.gauge;
  for (const PaletteEntry& entry : lines.palette)
    chart.palette.push_back(entry.linear);
  for (const StitchRow& row : lines.rows) {
    chart.cells.insert(chart.cells.end(), row.stitches.begin(), row.stitches.end());
    if (!row.colours) {
      chart.colour_index.insert(chart.colour_index.end(), row.stitches.size(), 0);
      continue;
    }
    for (const Symbol& symbol : row.colours->symbols) {
      std::size_t index = 0;
      while (index < lines.palette.size() && lines.palette[index].letter != symbol.letter)
        ++index;
      if (index == lines.palette.size())
        return std::unexpected(error_at(source, row.colours->line, symbol.column,
                                        std::string("colour letter '") + symbol.letter +
                                            "' is not in the palette (" +
                                            palette_letters(lines.palette) + ")"));
      chart.colour_index.push_back(static_cast<std::uint8_t>(index));
    }
  }
  return chart;
}

std::string format_stitch_chart(const StitchChart& chart, std::string_view comment) {
  std::string text;
  for (std::size_t start = 0; start < comment.size();) {
    const std::size_t end = std::min(comment.find('\n', start), comment.size());
    text += "# " + std::string(comment.substr(start, end - start)) + "\n";
    start = end + 1;
  }
  if (!chart.name.empty()) text += "name: " + chart.name + "\n";
  const auto key = [&](const char* name, float value) {
    if (value > 0) text += fmt::format("{}: {:.4g}\n", name, value);
  };
  key("wales_per_cm", chart.gauge.wales_per_cm);
  key("courses_per_cm", chart.gauge.courses_per_cm);
  key("yarn_mm", chart.gauge.yarn_diameter_mm);
  constexpr std::string_view kLetters = "ABCDEFGHIJKLMNOPQRSTUVWXYZ";
  const std::size_t colours = std::min(chart.palette.size(), kLetters.size());
  for (std::size_t i = 0; i < colours; ++i)
    text += fmt::format("colour {} {}\n", kLetters[i], format_srgb_hex(chart.palette[i]));
  for (int row = 0; row < chart.rows; ++row) {
    std::string stitches, letters;
    for (int column = 0; column < chart.columns; ++column) {
      stitches += column > 0 ? " " : "";
      stitches += chart.at(column, row) == Stitch::knit ? 'K' : 'P';
      letters += column > 0 ? " " : "";
      letters += kLetters[std::min<std::size_t>(static_cast<std::size_t>(chart.colour_at(column, row)),
                                                colours > 0 ? colours - 1 : 0)];
    }
    text += stitches + (row == 0 ? "   # row 0, the bottom course" : "") + "\n";
    if (colours > 1) text += "= " + letters + "\n";
  }
  return text;
}

Result<StitchChart> load_stitch_chart(const fs::path& file) {
  auto text = pattern_text::read_text_file(file);
  if (!text) return std::unexpected(text.error());
  return parse_stitch_chart(*text, file);
}

}  // namespace psrig::cloth
