// parse_width_height(): the WIDTHxHEIGHT text behind every --size and the
// kiosk's display mode; callers check the range.

#include "psrig/base/width_height.h"

#include <gtest/gtest.h>

namespace psrig {
namespace {

TEST(WidthHeight, ParsesWidthAndHeightAroundAnX) {
  for (const char* text : {"1920x1080", "1920X1080", "01920x01080"}) {
    const auto size = parse_width_height(text);
    ASSERT_TRUE(size) << text;
    EXPECT_EQ(size->width, 1920) << text;
    EXPECT_EQ(size->height, 1080) << text;
  }
  const auto zero = parse_width_height("0x0");  // in range is the caller's call
  ASSERT_TRUE(zero);
  EXPECT_EQ(zero->width, 0);
}

TEST(WidthHeight, AnythingElseIsNothing) {
  for (const char* text : {"", "x", "big", "1920", "1920x", "x1080", "-1920x1080", "1920x-1080",
                           "+1920x1080", "1920 x 1080", " 1920x1080", "1920x1080 ", "1920x1080x3",
                           "1920x1080@60", "99999999999x1080", "1920,1080", "1e3x1080"}) {
    EXPECT_FALSE(parse_width_height(text)) << text;
  }
}

}  // namespace
}  // namespace psrig
