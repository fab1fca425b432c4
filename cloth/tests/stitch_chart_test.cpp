// Stitch charts: the shipped patterns have the structure their names
// promise, the file is read bottom course first, the repeat tiles, colours
// land on the right stitches, and every mistake is reported at its line.

#include "psrig/cloth/stitch_chart.h"

#include <gtest/gtest.h>

#include "pattern_error.h"
#include "test_support.h"

namespace psrig::cloth {
namespace {

namespace fs = std::filesystem;

StitchChart shipped_chart(const std::string& file) {
  auto chart = load_stitch_chart(test::shipped_pattern(file));
  EXPECT_TRUE(chart) << chart.error().describe();
  return chart ? *chart : StitchChart{};
}

StitchChart parsed(std::string_view text) {
  auto chart = parse_stitch_chart(text, "test.chart");
  EXPECT_TRUE(chart) << chart.error().describe();
  return chart ? *chart : StitchChart{};
}

TEST(StitchChart, EveryShippedChartLoads) {
  int charts = 0;
  for (const fs::directory_entry& entry : fs::directory_iterator(test::shipped_pattern(""))) {
    if (entry.path().extension() != ".chart") continue;
    ++charts;
    auto chart = load_stitch_chart(entry.path());
    ASSERT_TRUE(chart) << chart.error().describe();
    EXPECT_GT(chart->columns, 0) << entry.path();
    EXPECT_GT(chart->rows, 0) << entry.path();
    EXPECT_EQ(chart->cells.size(), static_cast<std::size_t>(chart->columns * chart->rows));
    EXPECT_EQ(chart->colour_index.size(), chart->cells.size());
    EXPECT_FALSE(chart->name.empty()) << entry.path();
  }
  EXPECT_EQ(charts, 7);
}

TEST(StitchChart, StockinetteIsAllKnit) {
  const StitchChart chart = shipped_chart("stockinette.chart");
  for (const Stitch stitch : chart.cells)
    EXPECT_EQ(stitch, Stitch::knit);
  EXPECT_EQ(chart.palette.size(), 1U);
  // Its size in real units.
  EXPECT_FLOAT_EQ(chart.gauge.wales_per_cm, 7.0f);
  EXPECT_FLOAT_EQ(chart.gauge.courses_per_cm, 9.0f);
  EXPECT_FLOAT_EQ(chart.gauge.yarn_diameter_mm, 0.41f);
}

TEST(StitchChart, GarterCoursesAlternate) {
  const StitchChart chart = shipped_chart("garter.chart");
  EXPECT_EQ(chart.rows % 2, 0);
  EXPECT_EQ(chart.at(0, 0), Stitch::knit);
  for (int row = 0; row < chart.rows; ++row)
    for (int column = 0; column < chart.columns; ++column) {
      EXPECT_EQ(chart.at(column, row), chart.at(0, row)) << "each course is all one stitch";
      EXPECT_NE(chart.at(column, row), chart.at(column, row + 1)) << row;
    }
}

TEST(StitchChart, RibColumnsAlternate) {
  const std::pair<const char*, int> ribs[] = {{"rib-1x1.chart", 2}, {"rib-2x2.chart", 4}};
  for (const auto& [file, period] : ribs) {
    const StitchChart chart = shipped_chart(file);
    EXPECT_EQ(chart.columns % period, 0) << file;
    EXPECT_EQ(chart.at(0, 0), Stitch::knit) << file;
    for (int row = 0; row < chart.rows; ++row)
      for (int column = 0; column < chart.columns; ++column) {
        EXPECT_EQ(chart.at(column, row), chart.at(column, 0)) << file << " a wale is one stitch";
        EXPECT_EQ(chart.at(column, row), chart.at(column + period, row)) << file;
        EXPECT_NE(chart.at(column, row), chart.at(column + period / 2, row)) << file;
      }
  }
  // Within a period, the knit columns come together: K K P P, not K P K P.
  const StitchChart rib = shipped_chart("rib-2x2.chart");
  EXPECT_EQ(rib.at(1, 0), Stitch::knit);
}

TEST(StitchChart, SeedDiffersFromItsFourNeighbours) {
  const StitchChart chart = shipped_chart("seed.chart");
  for (int row = 0; row < chart.rows; ++row)
    for (int column = 0; column < chart.columns; ++column) {
      const Stitch stitch = chart.at(column, row);
      EXPECT_NE(stitch, chart.at(column + 1, row));
      EXPECT_NE(stitch, chart.at(column - 1, row));
      EXPECT_NE(stitch, chart.at(column, row + 1));
      EXPECT_NE(stitch, chart.at(column, row - 1));
    }
}

TEST(StitchChart, BasketweaveBlocksAlternateAndOffset) {
  const StitchChart chart = shipped_chart("basketweave.chart");
  ASSERT_EQ(chart.columns, 8);
  ASSERT_EQ(chart.rows, 8);
  for (int row = 0; row < chart.rows; ++row)
    for (int column = 0; column < chart.columns; ++column) {
      const Stitch stitch = chart.at(column, row);
      EXPECT_EQ(stitch, chart.at(column / 4 * 4, row / 4 * 4)) << "4x4 blocks";
      EXPECT_NE(stitch, chart.at(column + 4, row));
      EXPECT_NE(stitch, chart.at(column, row + 4));
    }
}

TEST(StitchChart, StripesChangeColourEveryTwoCourses) {
  const StitchChart chart = shipped_chart("stripes.chart");
  ASSERT_EQ(chart.palette.size(), 2u);
  ASSERT_EQ(chart.rows % 4, 0);
  for (int row = 0; row < chart.rows; ++row)
    for (int column = 0; column < chart.columns; ++column) {
      EXPECT_EQ(chart.at(column, row), Stitch::knit);
      EXPECT_EQ(chart.colour_at(column, row), row % 4 < 2 ? 0 : 1) << row;
    }
  EXPECT_GT(chart.palette[0].sum(), chart.palette[1].sum()) << "cream is lighter than navy";
}

TEST(StitchChart, FirstRowInTheFileIsTheBottomCourse) {
  const StitchChart chart = parsed("KK\nPP\n");
  ASSERT_EQ(chart.rows, 2);
  EXPECT_EQ(chart.at(0, 0), Stitch::knit);
  EXPECT_EQ(chart.at(1, 0), Stitch::knit);
  EXPECT_EQ(chart.at(0, 1), Stitch::purl);
  EXPECT_EQ(chart.cells.front(), Stitch::knit);  // row-major from row 0
}

TEST(StitchChart, TilesInBothDirectionsIncludingNegative) {
  const StitchChart chart = parsed("K P P\nP K K\n");
  ASSERT_EQ(chart.columns, 3);
  for (int row = -7; row <= 7; ++row)
    for (int column = -10; column <= 10; ++column) {
      const int wrapped_column = ((column % 3) + 3) % 3, wrapped_row = ((row % 2) + 2) % 2;
      EXPECT_EQ(chart.at(column, row), chart.at(wrapped_column, wrapped_row))
          << column << ", " << row;
    }
  EXPECT_EQ(chart.at(-1, 0), Stitch::purl);
  EXPECT_EQ(chart.at(-3, -1), Stitch::purl);
  EXPECT_EQ(chart.at(-2, -1), Stitch::knit);
  EXPECT_EQ(chart.colour_at(-5, -3), 0);
}

TEST(StitchChart, CaseSpacesCommentsAndName) {
  const StitchChart chart = parsed(
      "# a header\n"
      "\n"
      "name: Little rib  # the name\n"
      "  k\tp   # row 0\r\n"
      "KP\n");
  EXPECT_EQ(chart.name, "Little rib");
  ASSERT_EQ(chart.columns, 2);
  ASSERT_EQ(chart.rows, 2);
  EXPECT_EQ(chart.at(0, 0), Stitch::knit);
  EXPECT_EQ(chart.at(1, 0), Stitch::purl);
  EXPECT_EQ(parsed("K\n").name, "test") << "without a name line, the file's stem";
}

TEST(StitchChart, ColourRowsColourTheRowBeforeThem) {
  const StitchChart chart = parsed(
      "colour W #FFFFFF\n"
      "colour G #808080  # mid grey\n"
      "K K K\n"
      "= G W G\n"
      "P P P\n"  // no colour row: palette entry 0
      "K P K\n"
      "=GGW\n");
  ASSERT_EQ(chart.palette.size(), 2u);
  EXPECT_TRUE(chart.palette[0].isApprox(Eigen::Vector3f(1, 1, 1)));
  for (int channel = 0; channel < 3; ++channel)
    EXPECT_NEAR(chart.palette[1][channel], 0.2158, 1e-3);  // sRGB 128 in linear light
  const std::vector<std::uint8_t> expected = {1, 0, 1, 0, 0, 0, 1, 1, 0};
  EXPECT_EQ(chart.colour_index, expected);
  EXPECT_EQ(chart.colour_at(2, 2), 0);
  EXPECT_EQ(chart.colour_at(-1, -1), 0);
  EXPECT_EQ(chart.colour_at(-2, -1), 1);
}

TEST(StitchChart, PaletteMayComeAfterTheRowsThatUseIt) {
  const StitchChart chart = parsed("K\n= B\ncolour A #000000\ncolour B #FF0000\n");
  ASSERT_EQ(chart.palette.size(), 2u);
  EXPECT_EQ(chart.colour_at(0, 0), 1);
  EXPECT_TRUE(chart.palette[1].isApprox(Eigen::Vector3f(1, 0, 0)));
}

TEST(StitchChart, ErrorsNameTheFileLineAndColumn) {
  const test::BadPattern cases[] = {
      {"KKK\nKK\n", 2, 1, "row 1 has 2 stitches, expected 3"},
      {"KK\n\nK X\n", 3, 3, "unknown symbol 'X'"},
      {"colour A #FFFFFF\nKKK\n= AA\n", 3, 1, "colour row has 2 letters"},
      {"colour A #FFFFFF\nKK\n= AC\n", 3, 4, "colour letter 'C' is not in the palette"},
      {"KK\n= AA\n", 2, 3, "no `colour` lines"},
      {"colour A #FFF\nK\n", 1, 10, "malformed colour '#FFF'"},
      {"colour A #GG0000\nK\n", 1, 10, "malformed colour '#GG0000'"},
      {"colour A\nK\n", 1, 8, "'A' has no value"},
      {"# header\n= A\nK\n", 2, 1, "colour row (=)"},
      {"colour A #000000\nK\n= A\n= A\n", 4, 1, "already has a colour row"},
      {"colour A #000000\ncolour A #FFFFFF\nK\n", 2, 8, "already given on line 1"},
      {"colour AB #000000\nK\n", 1, 8, "one letter or digit"},
      {"name: a\nname: b\nK\n", 2, 1, "second `name:`"},
  };
  for (const test::BadPattern& bad : cases) {
    auto chart = parse_stitch_chart(bad.text, "bad.chart");
    ASSERT_FALSE(chart) << bad.text;
    test::expect_bad_pattern_error(chart.error(), "bad.chart", bad);
  }
}

TEST(StitchChart, AChartWithoutStitchRowsIsAnError) {
  for (const char* text : {"", "# only a comment\n\nname: nothing\n", "colour A #000000\n"}) {
    auto chart = parse_stitch_chart(text, "empty.chart");
    ASSERT_FALSE(chart) << text;
    EXPECT_EQ(exit_code(chart.error()), 2);
    EXPECT_NE(chart.error().describe().find("empty.chart"), std::string::npos);
    EXPECT_NE(chart.error().describe().find("no stitch rows"), std::string::npos);
  }
}

TEST(StitchChart, AnUnreadableFileIsAnIoError) {
  const test::TempDir temp;
  auto chart = load_stitch_chart(temp / "absent.chart");
  ASSERT_FALSE(chart);
  EXPECT_EQ(chart.error().kind, ErrorKind::bad_input);  // the user's to fix: exit 2
  EXPECT_NE(chart.error().describe().find("absent.chart"), std::string::npos);
}

}  // namespace
}  // namespace psrig::cloth
