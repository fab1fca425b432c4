// Which centreline points a frame draws: straight runs long, bends short
// enough to keep the chord on the curve, lift and colour changes kept, and
// the strip's sides alternating.

#include "psrig/preview/strip_points.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

namespace psrig::preview {
namespace {

// A circle of `radius` mm sampled every `spacing` mm (its turn per point).
std::vector<CentrelinePoint> arc(int count, float spacing, float radius) {
  std::vector<CentrelinePoint> points(static_cast<std::size_t>(count));
  for (CentrelinePoint& point : points) {
    point.length_mm = spacing;
    point.turn = radius > 0 ? spacing / radius : 0;
  }
  points.back().length_mm = 0;
  return points;
}

std::vector<std::uint32_t> strip(const std::vector<CentrelinePoint>& points, float px_per_mm,
                                 const PieceLimits& limits = {}) {
  std::vector<std::uint32_t> indices;
  append_strip(points, 0, points.size(), px_per_mm, limits, indices);
  return indices;
}

void expect_alternating(const std::vector<std::uint32_t>& indices) {
  for (std::size_t k = 1; k + 1 < indices.size(); ++k)
    EXPECT_NE(indices[k] & 1U, indices[k - 1] & 1U) << "at " << k;
  EXPECT_EQ(indices.back(), kRestartIndex);
}

TEST(StripPoints, StraightYarnRunsToTheLongestPiece) {
  const auto points = arc(401, 0.25f, 0);  // 100 mm straight
  const PieceLimits limits;
  const auto indices = strip(points, 4, limits);  // 1 px a point
  expect_alternating(indices);
  EXPECT_EQ(indices.front(), 0U);
  EXPECT_EQ(indices[indices.size() - 2], 400U) << "ends at the last point";
  const double pieces = static_cast<double>(indices.size() - 2);
  EXPECT_NEAR(pieces, 400.0 / limits.max_px, 3.0);
}

TEST(StripPoints, BendsKeepTheChordWithinTolerance) {
  const float radius = 2, spacing = 0.05f, px_per_mm = 20;
  const auto points = arc(600, spacing, radius);
  const PieceLimits limits;
  const auto indices = strip(points, px_per_mm, limits);
  expect_alternating(indices);
  for (std::size_t k = 1; k + 1 < indices.size(); ++k) {
    const float chord_mm = static_cast<float>(indices[k] - indices[k - 1]) * spacing;
    const float sagitta_px = chord_mm * chord_mm / (8 * radius) * px_per_mm;
    EXPECT_LE(sagitta_px, limits.tolerance_px * 1.2f + 0.05f) << "piece " << k;
  }
  // Smaller on screen, fewer pieces: the same bend is less of a pixel
  // (a quarter the size, half the pieces: the sagitta goes as length squared).
  EXPECT_LT(strip(points, px_per_mm / 4, limits).size(), 0.6 * indices.size());
}

TEST(StripPoints, NoPieceShorterThanTheLeastUnlessKept) {
  auto points = arc(200, 0.1f, 0.3f);  // tight bends, 1 px a point
  PieceLimits limits;
  const auto indices = strip(points, 10, limits);
  for (std::size_t k = 2; k + 2 < indices.size(); ++k)
    EXPECT_GE((indices[k] - indices[k - 1]) * 1.0f, limits.min_px - 1) << k;
  // A colour change is drawn where it is, whatever the limits.
  points[77].keep = true;
  const auto kept = strip(points, 10, limits);
  EXPECT_TRUE(std::find(kept.begin(), kept.end(), 77U) != kept.end() ||
              std::find(kept.begin(), kept.end(), 76U) != kept.end());
}

TEST(StripPoints, LiftStaysWithinToleranceOfTheStrip) {
  // Straight, lift 1 down to 0 at the middle and back up: a chord straight
  // over the kink would lose the dip.
  auto points = arc(201, 0.1f, 0);
  const auto lift = [](std::uint32_t i) { return std::abs(static_cast<float>(i) - 100) / 100; };
  points[100].lift_turn = 2 * 1.0f / 10;  // slope -0.1 per mm to +0.1 per mm
  const PieceLimits limits;
  const auto indices = strip(points, 2, limits);
  for (std::size_t k = 1; k + 1 < indices.size(); ++k)
    for (std::uint32_t i = indices[k - 1]; i <= indices[k]; ++i) {
      const float t = static_cast<float>(i - indices[k - 1]) / static_cast<float>(indices[k] - indices[k - 1]);
      const float drawn = lift(indices[k - 1]) + t * (lift(indices[k]) - lift(indices[k - 1]));
      EXPECT_LE(std::abs(drawn - lift(i)), limits.lift_tolerance + 1e-4f) << "point " << i;
    }
}

TEST(StripPoints, TooShortYarnsDrawNothing) {
  const auto points = arc(2, 0.1f, 0);
  EXPECT_TRUE(strip(points, 10).empty());
}

}  // namespace
}  // namespace psrig::preview
