// Weave matrices: the shipped weaves have the structure their names
// promise, the first row is the first weft, the repeat tiles, and mistakes
// are reported at their line.

#include "psrig/cloth/weave_matrix.h"
#include "psrig/cloth/woven_dataset_generator.h"

#include <gtest/gtest.h>

#include "pattern_error.h"
#include "test_support.h"

namespace psrig::cloth {
namespace {

namespace fs = std::filesystem;

WeaveMatrix shipped_weave(const std::string& file) {
  auto matrix = load_weave_matrix(test::shipped_pattern(file));
  EXPECT_TRUE(matrix) << matrix.error().describe();
  return matrix ? *matrix : WeaveMatrix{};
}

TEST(WeaveMatrix, EveryShippedWeaveLoads) {
  int weaves = 0;
  for (const fs::directory_entry& entry : fs::directory_iterator(test::shipped_pattern(""))) {
    if (!looks_like_weave(entry.path())) continue;
    ++weaves;
    auto matrix = load_weave_matrix(entry.path());
    ASSERT_TRUE(matrix) << matrix.error().describe();
    EXPECT_GT(matrix->warps, 0);
    EXPECT_GT(matrix->wefts, 0);
    EXPECT_EQ(matrix->cells.size(), static_cast<std::size_t>(matrix->warps * matrix->wefts));
    EXPECT_FALSE(matrix->name.empty());
  }
  EXPECT_EQ(weaves, 3);
}

TEST(WeaveMatrix, PlainIsACheckerboard) {
  const WeaveMatrix plain = shipped_weave("plain.weave");
  for (int weft = 0; weft < plain.wefts; ++weft)
    for (int warp = 0; warp < plain.warps; ++warp) {
      EXPECT_NE(plain.warp_over(warp, weft), plain.warp_over(warp + 1, weft));
      EXPECT_NE(plain.warp_over(warp, weft), plain.warp_over(warp, weft + 1));
    }
}

TEST(WeaveMatrix, TwillShiftsOneWarpPerWeft) {
  const WeaveMatrix twill = shipped_weave("twill-2x2.weave");
  ASSERT_EQ(twill.warps, 4);
  ASSERT_EQ(twill.wefts, 4);
  for (int weft = 0; weft < twill.wefts; ++weft) {
    int over = 0;
    for (int warp = 0; warp < twill.warps; ++warp) {
      EXPECT_EQ(twill.warp_over(warp, weft + 1), twill.warp_over(warp - 1, weft))
          << warp << ", " << weft;
      over += twill.warp_over(warp, weft) ? 1 : 0;
    }
    EXPECT_EQ(over, 2) << "2/2: two warps over, two under";
  }
}

TEST(WeaveMatrix, SatinCrossingsAreAloneInRowColumnAndNeighbourhood) {
  const WeaveMatrix satin = shipped_weave("satin-5.weave");
  ASSERT_EQ(satin.warps, 5);
  ASSERT_EQ(satin.wefts, 5);
  for (int i = 0; i < 5; ++i) {
    int in_weft = 0, in_warp = 0;
    for (int j = 0; j < 5; ++j) {
      in_weft += satin.warp_over(j, i) ? 1 : 0;
      in_warp += satin.warp_over(i, j) ? 1 : 0;
    }
    EXPECT_EQ(in_weft, 1) << "weft " << i;
    EXPECT_EQ(in_warp, 1) << "warp " << i;
  }
  for (int weft = 0; weft < 5; ++weft)
    for (int warp = 0; warp < 5; ++warp) {
      if (!satin.warp_over(warp, weft)) continue;
      EXPECT_FALSE(satin.warp_over(warp + 1, weft));
      EXPECT_FALSE(satin.warp_over(warp - 1, weft));
      EXPECT_FALSE(satin.warp_over(warp, weft + 1));
      EXPECT_FALSE(satin.warp_over(warp, weft - 1));
    }
}

TEST(WeaveMatrix, FirstRowIsTheFirstWeftAndTheRepeatTiles) {
  auto matrix = parse_weave_matrix("name: test weave\n1 1 0  # weft 0\n\n000\r\n", "t.weave");
  ASSERT_TRUE(matrix) << matrix.error().describe();
  EXPECT_EQ(matrix->name, "test weave");
  ASSERT_EQ(matrix->warps, 3);
  ASSERT_EQ(matrix->wefts, 2);
  EXPECT_TRUE(matrix->warp_over(0, 0));
  EXPECT_FALSE(matrix->warp_over(0, 1));
  EXPECT_TRUE(matrix->warp_over(-2, -2));
  EXPECT_FALSE(matrix->warp_over(-1, 0));
  EXPECT_FALSE(matrix->warp_over(-3, -1));
  EXPECT_TRUE(matrix->warp_over(4, 6));
  EXPECT_EQ(parse_weave_matrix("1\n", "dir/plain.weave")->name, "plain");
}

// chen2024's alpha and beta, when the file gives them: what the neural far
// level encodes the weave with (woven_far_material).
TEST(WeaveMatrix, ReadsTheLookWhereGiven) {
  auto given = parse_weave_matrix("roughness: 0.3\nheight_scale: 1.5\n10\n01\n", "look.weave");
  ASSERT_TRUE(given) << given.error().describe();
  EXPECT_FLOAT_EQ(given->roughness, 0.3f);
  EXPECT_FLOAT_EQ(given->height_scale, 1.5f);
  auto absent = parse_weave_matrix("10\n01\n", "plain.weave");
  ASSERT_TRUE(absent);
  EXPECT_EQ(absent->roughness, 0.0f);
  EXPECT_EQ(absent->height_scale, 0.0f);
  // The network's parameters: the file's, or the defaults.
  EXPECT_FLOAT_EQ(weave_parameters(*given).alpha, 0.3f);
  EXPECT_FLOAT_EQ(weave_parameters(*given).beta, 1.5f);
  EXPECT_FLOAT_EQ(weave_parameters(*absent).alpha, WovenMaterialParameters{}.alpha);
  EXPECT_FLOAT_EQ(weave_parameters(*absent).beta, WovenMaterialParameters{}.beta);
}

TEST(WeaveMatrix, ErrorsNameTheFileLineAndColumn) {
  const test::BadPattern cases[] = {
      {"# twill\n1100\n011\n", 3, 1, "row 1 has 3 crossings, expected 4"},
      {"1 0\n0 x\n", 2, 3, "unknown symbol 'x'"},
      {"1 0\n0 K\n", 2, 3, "unknown symbol 'K'"},
      {"name: a\nname: b\n1\n", 2, 1, "second `name:`"},
      {"roughness: 1.5\n1\n", 1, 12, "roughness must be within 0.1 to 1"},
      {"roughness: 0.05\n1\n", 1, 12, "roughness must be within 0.1 to 1"},
      {"height_scale: 3\n1\n", 1, 15, "height_scale must be within 0 to 2"},
      {"height_scale: 0\n1\n", 1, 15, "height_scale must be a positive number"},
  };
  for (const test::BadPattern& bad : cases) {
    auto matrix = parse_weave_matrix(bad.text, "bad.weave");
    ASSERT_FALSE(matrix) << bad.text;
    test::expect_bad_pattern_error(matrix.error(), "bad.weave", bad);
  }
  auto empty = parse_weave_matrix("# nothing\n\n", "empty.weave");
  ASSERT_FALSE(empty);
  EXPECT_EQ(exit_code(empty.error()), 2);
  EXPECT_NE(empty.error().describe().find("empty.weave"), std::string::npos);
  EXPECT_NE(empty.error().describe().find("no rows"), std::string::npos);

  const test::TempDir temp;
  auto absent = load_weave_matrix(temp / "absent.weave");
  ASSERT_FALSE(absent);
  EXPECT_EQ(absent.error().kind, ErrorKind::bad_input);  // the user's to fix: exit 2
  EXPECT_NE(absent.error().describe().find("absent.weave"), std::string::npos);
}

TEST(WeaveMatrix, LooksLikeWeaveByExtension) {
  EXPECT_TRUE(looks_like_weave("config/patterns/plain.weave"));
  EXPECT_TRUE(looks_like_weave("TWILL.WEAVE"));
  EXPECT_FALSE(looks_like_weave("config/patterns/seed.chart"));
  EXPECT_FALSE(looks_like_weave("weave"));
}

}  // namespace
}  // namespace psrig::cloth
