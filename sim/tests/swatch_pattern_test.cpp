// What the simulated swatch is made of: shipped patterns by name (and the
// simulator's older names), chart and weave files by path, the gauge the
// cloth built from them has, how many threads one repeat holds, and clear
// errors for what cannot be used.

#include "psrig/sim/swatch_pattern.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "psrig/cloth/knit_fabric.h"
#include "shipped_swatch.h"
#include "test_support.h"

namespace psrig::sim {
namespace {

namespace fs = std::filesystem;

TEST(SwatchPattern, EveryShippedPatternLoadsByName) {
  // Every pattern file shipped, and only those.
  std::vector<std::string> files;
  for (const auto& entry : fs::directory_iterator(test::shipped_pattern("")))
    if (entry.path().extension() == ".chart" || entry.path().extension() == ".weave")
      files.push_back(entry.path().stem().string());
  std::vector<std::string> names = shipped_pattern_names();
  std::ranges::sort(files);
  std::ranges::sort(names);
  EXPECT_EQ(names, files);
  EXPECT_EQ(test::shipped_pattern_names().size(), names.size());
  const fs::path folder = find_patterns_dir();
  ASSERT_FALSE(folder.empty());
  for (const std::string& name : shipped_pattern_names()) {
    const SwatchPattern pattern = test::named_pattern(name);
    EXPECT_EQ(pattern.name, name);
    EXPECT_EQ(pattern.file.parent_path(), folder) << name;
    EXPECT_EQ(pattern.file.stem(), name);
    EXPECT_EQ(pattern.knitted(), pattern.file.extension() == ".chart") << name;
    EXPECT_EQ(pattern.gauge.knitted, pattern.knitted()) << name;
    EXPECT_GT(pattern.gauge.across_per_cm, 3) << name;
    EXPECT_GT(pattern.gauge.along_per_cm, 3) << name;
  }
}

// The older names are the shipped patterns they stood for, at the gauge the
// simulator made them to (issue 16's truth).
TEST(SwatchPattern, OlderNamesAreAliasesKeptAsTheStructure) {
  struct Alias {
    const char* older;
    const char* shipped;
    double across, along;
  };
  for (const Alias& a : {Alias{"jersey", "stockinette", 7.0, 9.0},
                         Alias{"rib", "rib-1x1", 11.1, 9.0}, Alias{"garter", "garter", 6.25, 12.5},
                         Alias{"plain", "plain", 24, 22}, Alias{"twill", "twill-2x2", 26, 19}}) {
    const SwatchPattern pattern = test::named_pattern(a.older);
    EXPECT_EQ(pattern.name, a.older);
    EXPECT_EQ(pattern.file.stem(), a.shipped);
    EXPECT_NEAR(pattern.gauge.across_per_cm, a.across, 1e-4) << a.older;
    EXPECT_NEAR(pattern.gauge.along_per_cm, a.along, 1e-4) << a.older;
  }
}

// A chart without a gauge: the cloth's own repeat (a 2x2 rib drawn in from
// a jersey of the default yarn) is the truth.
TEST(SwatchPattern, TheGaugeIsTheClothsRepeat) {
  const SwatchPattern rib = test::named_pattern("rib-2x2");
  const auto& chart = std::get<cloth::StitchChart>(rib.cloth);
  const auto fabric = test::made(cloth::KnitFabric::build(chart, 8, 3, {}));
  EXPECT_NEAR(rib.gauge.across_per_cm, 10.0 * chart.columns / fabric.repeat().width_mm, 1e-6);
  EXPECT_NEAR(rib.gauge.along_per_cm, 10.0 * chart.rows / fabric.repeat().height_mm, 1e-6);
  // Drawn in: more wales per cm than the jersey of its yarn.
  EXPECT_GT(rib.gauge.across_per_cm, 10.0 / fabric.dimensions().wale_mm);
}

TEST(SwatchPattern, ThreadsPerRepeatAreThePatternsOwnPeriod) {
  struct Count {
    const char* name;
    int across, along;
  };
  for (const Count& c : {Count{"stockinette", 1, 1}, Count{"garter", 1, 2}, Count{"rib-1x1", 2, 1},
                         Count{"rib-2x2", 4, 1}, Count{"seed", 2, 2}, Count{"basketweave", 8, 8},
                         Count{"stripes", 1, 4}, Count{"plain", 2, 2}, Count{"twill-2x2", 4, 4},
                         Count{"satin-5", 5, 5}}) {
    const SwatchPattern pattern = test::named_pattern(c.name);
    EXPECT_EQ(pattern.gauge.across_per_repeat, c.across) << c.name;
    EXPECT_EQ(pattern.gauge.along_per_repeat, c.along) << c.name;
  }
  // A file that writes its repeat out twice: the repeat is the smaller one.
  auto twice = cloth::parse_stitch_chart("K P K P\nK P K P\n", "twice.chart");
  ASSERT_TRUE(twice);
  const SwatchPattern pattern = test::made(swatch_pattern(*twice, "twice"));
  EXPECT_EQ(pattern.gauge.across_per_repeat, 2);
  EXPECT_EQ(pattern.gauge.along_per_repeat, 1);
}

TEST(SwatchPattern, AFileByPathRelativeToAFolder) {
  test::TempDir temp;
  fs::create_directories(temp / "mine");
  std::ofstream(temp / "mine" / "moss.chart") << "name: moss\nK P\nP K\n";
  const SwatchPattern moss = test::made(load_swatch_pattern("mine/moss.chart", {}, temp.path()));
  EXPECT_EQ(moss.name, "moss");
  EXPECT_TRUE(moss.knitted());
  EXPECT_EQ(moss.file, temp / "mine" / "moss.chart");
  std::ofstream(temp / "duck.weave") << "1 1 0\n0 1 1\n1 0 1\n";
  const SwatchPattern duck = test::made(load_swatch_pattern((temp / "duck.weave").string()));
  EXPECT_EQ(duck.name, "duck");  // no name: line, the file's stem
  EXPECT_FALSE(duck.knitted());
}

// A configured folder of patterns ([sim] patterns_dir) is where names are found.
TEST(SwatchPattern, NamesAreFoundInAConfiguredFolder) {
  test::TempDir temp;
  std::ofstream(temp / "stockinette.chart") << "wales_per_cm: 5\ncourses_per_cm: 6.5\nK\n";
  const SwatchPattern jersey = test::made(load_swatch_pattern("jersey", temp.path()));
  EXPECT_EQ(jersey.file, temp / "stockinette.chart");
  EXPECT_NEAR(jersey.gauge.across_per_cm, 5, 1e-5);
  const auto missing = load_swatch_pattern("seed", temp.path(), {}, "sim.pattern");
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().message.find(temp.path().string()), std::string::npos)
      << missing.error().describe();
}

TEST(SwatchPattern, WhatCannotBeUsedIsBadInputNamingTheKeyAndTheFix) {
  const auto unknown = load_swatch_pattern("argyle", {}, {}, "--pattern");
  ASSERT_FALSE(unknown);
  EXPECT_EQ(unknown.error().kind, ErrorKind::bad_input);
  EXPECT_EQ(unknown.error().key, "--pattern");
  for (const char* part : {"argyle", ".chart", "stockinette", "satin-5", "jersey"})
    EXPECT_NE(unknown.error().message.find(part), std::string::npos) << unknown.error().describe();

  test::TempDir temp;
  const auto absent = load_swatch_pattern((temp / "gone.chart").string(), {}, {}, "--pattern");
  ASSERT_FALSE(absent);
  EXPECT_EQ(absent.error().kind, ErrorKind::bad_input);
  EXPECT_EQ(absent.error().file, temp / "gone.chart");
  EXPECT_EQ(absent.error().key, "--pattern");

  // A mistake in the chart: its line and column.
  std::ofstream(temp / "typo.chart") << "K P\nK Q\n";
  const auto typo = load_swatch_pattern((temp / "typo.chart").string());
  ASSERT_FALSE(typo);
  EXPECT_EQ(typo.error().file, temp / "typo.chart");
  EXPECT_EQ(typo.error().line, 2);

  // A yarn no knit of that gauge holds together: the file and yarn_mm.
  std::ofstream(temp / "rope.chart") << "wales_per_cm: 7\ncourses_per_cm: 9\nyarn_mm: 3\nK\n";
  const auto rope = load_swatch_pattern((temp / "rope.chart").string());
  ASSERT_FALSE(rope);
  EXPECT_EQ(rope.error().kind, ErrorKind::bad_input);
  EXPECT_EQ(rope.error().file, temp / "rope.chart");
  EXPECT_EQ(rope.error().key, "yarn_mm");
}

}  // namespace
}  // namespace psrig::sim
