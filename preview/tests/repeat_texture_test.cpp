// The far level's repeat (repeat_texture.h): the window of whole repeats
// in the mesh's middle, the yarns about it, and the texture's levels from
// the two bakes (coverage from what shows through, premultiplied colour,
// every level the mean of the finer one's).

#include "psrig/preview/repeat_texture.h"

#include <gtest/gtest.h>

#include "psrig/cloth/srgb.h"

namespace psrig::preview {
namespace {

cloth::YarnSurface flat_surface(int columns, int rows, int repeat_columns, int repeat_rows) {
  return {cloth::make_stitch_mesh(columns, rows, 2.0f, 1.5f, cloth::ClothShape::flat),
          repeat_columns, repeat_rows};
}

TEST(RepeatTexture, TheWindowIsAWholeRepeatInTheMiddle) {
  const auto window = middle_repeat(flat_surface(12, 9, 4, 3));
  ASSERT_TRUE(window);
  EXPECT_EQ(window->first_column, 4);
  EXPECT_EQ(window->first_row, 3);
  EXPECT_NEAR(window->across.norm(), 8.0f, 1e-4f);
  EXPECT_NEAR(window->up.norm(), 4.5f, 1e-4f);
  EXPECT_NEAR(std::abs(window->normal().z()), 1.0f, 1e-5f);
  EXPECT_FALSE(middle_repeat(flat_surface(3, 9, 4, 3))) << "narrower than one repeat";
  EXPECT_FALSE(middle_repeat({})) << "no surface";
}

TEST(RepeatTexture, WindowYarnsKeepRunsNearTheWindow) {
  const auto window = middle_repeat(flat_surface(12, 9, 4, 3));
  ASSERT_TRUE(window);
  cloth::YarnSet yarns;
  cloth::YarnCurve& curve = yarns.curves.emplace_back();
  for (float x = -20; x <= 20; x += 0.5f)
    curve.points.emplace_back(x, window->centre().y(), 0);
  const cloth::YarnSet near = window_yarns(yarns, *window, 1.0f);
  ASSERT_EQ(near.curves.size(), 1u);
  for (const Eigen::Vector3f& point : near.curves[0].points)
    EXPECT_LT(std::abs(point.x() - window->centre().x()), 4.0f + 1.0f + 1e-4f);
  EXPECT_GE(near.curves[0].points.size(), 16u);
}

TEST(RepeatTexture, LevelsArePremultipliedCoverageAndTheirMeans) {
  // Left half a yarn of linear 0.2 grey, right half open (black over black,
  // white over white).
  const std::uint8_t grey = static_cast<std::uint8_t>(std::lround(cloth::srgb_encode(0.2f) * 255));
  cv::Mat black(4, 8, CV_8UC3, cv::Scalar::all(0)), white(4, 8, CV_8UC3, cv::Scalar::all(255));
  black(cv::Rect(0, 0, 4, 4)).setTo(cv::Scalar::all(grey));
  white(cv::Rect(0, 0, 4, 4)).setTo(cv::Scalar::all(grey));
  const std::vector<cv::Mat> levels = repeat_levels(repeat_texels(black, white));
  ASSERT_EQ(levels.size(), 4u);  // 8x4, 4x2, 2x1, 1x1
  EXPECT_EQ(levels.back().size(), cv::Size(1, 1));
  const cv::Vec4f left = levels[0].at<cv::Vec4f>(0, 0), right = levels[0].at<cv::Vec4f>(0, 7);
  EXPECT_NEAR(left[0], 0.2f, 0.003f);
  EXPECT_NEAR(left[3], 1.0f, 1e-5f);
  EXPECT_NEAR(right[0], 0.0f, 1e-5f);
  EXPECT_NEAR(right[3], 0.0f, 1e-5f);
  const cv::Vec4f mean = levels.back().at<cv::Vec4f>(0, 0);
  EXPECT_NEAR(mean[0], 0.1f, 0.002f) << "premultiplied colour, averaged";
  EXPECT_NEAR(mean[3], 0.5f, 1e-5f) << "coverage, averaged";
}

// The area table gives any box's sum in four lookups, across the repeat's
// edge too (the 2x2 tiling), to float precision: what far_cloth.frag
// divides by the box's area for the mean over a pixel's footprint.
TEST(RepeatTexture, TheAreaTableSumsAnyBoxOfTheTiledRepeat) {
  cv::Mat level(8, 16, CV_32FC4);
  cv::randu(level, cv::Scalar::all(0), cv::Scalar::all(1));
  const AreaTable table = repeat_area_table(level);
  ASSERT_EQ(table.sums.size(), cv::Size(33, 17));
  const auto sum_at = [&](int x, int y) { return table.sums.at<cv::Vec4f>(y, x); };
  struct Box {
    int x0, y0, x1, y1;
  };
  for (const Box box :
       {Box{0, 0, 16, 8}, Box{3, 2, 7, 5}, Box{12, 6, 21, 11}, Box{15, 7, 31, 15}}) {
    cv::Vec4d direct = 0;
    for (int y = box.y0; y < box.y1; ++y)
      for (int x = box.x0; x < box.x1; ++x)
        direct += cv::Vec4d(level.at<cv::Vec4f>(y % 8, x % 16));
    const cv::Vec4f looked_up = sum_at(box.x1, box.y1) - sum_at(box.x0, box.y1) -
                                sum_at(box.x1, box.y0) + sum_at(box.x0, box.y0);
    const double texels = (box.x1 - box.x0) * (box.y1 - box.y0);
    for (int c = 0; c < 4; ++c)
      EXPECT_NEAR(looked_up[c] / texels + table.mean[c], direct[c] / texels, 1e-5)
          << "box from (" << box.x0 << ", " << box.y0 << ") to (" << box.x1 << ", " << box.y1
          << "), channel " << c;
  }
  // A whole repeat sums to nothing once its mean is off: the table stays
  // near zero however large the repeat.
  for (int c = 0; c < 4; ++c)
    EXPECT_NEAR(sum_at(16, 8)[c], 0.0f, 1e-4f);
}

}  // namespace
}  // namespace psrig::preview
