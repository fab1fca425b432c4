// The test bench itself: the emulated GPIO chip answers libgpiod 1.6 the
// way the kernel's v1 uAPI does, so what the backend tests see is what a
// board would do.

#include "emulated_gpio_chip.h"

#include <cerrno>
#include <cstring>
#include <gpiod.h>
#include <memory>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "umockdev_bed.h"

namespace psrig::test {
namespace {

struct ChipCloser {
  void operator()(gpiod_chip* chip) const { gpiod_chip_close(chip); }
};
using ChipPtr = std::unique_ptr<gpiod_chip, ChipCloser>;

EmulatedGpioChip::Options chip_options(const std::string& name, unsigned minor, unsigned lines,
                                       int initial_level = 0) {
  EmulatedGpioChip::Options options;
  options.name = name;
  options.label = "bench";
  options.lines = lines;
  options.minor = minor;
  options.initial_level = initial_level;
  return options;
}

TEST(EmulatedGpioChip, LibgpiodSeesTheChipAndItsLines) {
  if (!UmockdevBed::available()) GTEST_SKIP() << "not under umockdev-wrapper";
  UmockdevBed bed;
  EmulatedGpioChip chip(bed, chip_options("gpiochip2", 2, 8));
  chip.hold(3, "reset-gpios");

  ChipPtr open{gpiod_chip_open_by_name("gpiochip2")};
  ASSERT_TRUE(open) << std::strerror(errno);
  EXPECT_STREQ(gpiod_chip_name(open.get()), "gpiochip2");
  EXPECT_EQ(gpiod_chip_num_lines(open.get()), 8u);
  gpiod_line* held = gpiod_chip_get_line(open.get(), 3);
  ASSERT_TRUE(held);
  EXPECT_TRUE(gpiod_line_is_used(held));
  EXPECT_STREQ(gpiod_line_consumer(held), "reset-gpios");
  EXPECT_EQ(gpiod_line_request_output(held, "me", 0), -1);
  EXPECT_EQ(errno, EBUSY);
  EXPECT_EQ(gpiod_chip_get_line(open.get(), 8), nullptr);
}

TEST(EmulatedGpioChip, ActiveLowInvertsWhatTheHandleSeesNotTheLine) {
  if (!UmockdevBed::available()) GTEST_SKIP() << "not under umockdev-wrapper";
  UmockdevBed bed;
  EmulatedGpioChip chip(bed, chip_options("gpiochip0", 0, 8, 1));
  ChipPtr open{gpiod_chip_open("/dev/gpiochip0")};
  ASSERT_TRUE(open) << std::strerror(errno);

  gpiod_line* out = gpiod_chip_get_line(open.get(), 5);
  ASSERT_TRUE(out);
  ASSERT_EQ(gpiod_line_request_output_flags(out, "bench", GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW, 1),
            0);
  EXPECT_EQ(chip.levels()[5], 0);
  EXPECT_EQ(gpiod_line_get_value(out), 1);
  EXPECT_EQ(gpiod_line_active_state(out), GPIOD_LINE_ACTIVE_STATE_LOW);
  EXPECT_EQ(gpiod_line_direction(out), GPIOD_LINE_DIRECTION_OUTPUT);
  ASSERT_EQ(gpiod_line_set_value(out, 0), 0);
  EXPECT_EQ(chip.levels()[5], 1);

  gpiod_line* in = gpiod_chip_get_line(open.get(), 6);
  ASSERT_TRUE(in);
  ASSERT_EQ(gpiod_line_request_input(in, "bench"), 0);
  EXPECT_EQ(gpiod_line_get_value(in), 1);  // the level it idled at
  EXPECT_EQ(gpiod_line_set_value(in, 0), -1);
  EXPECT_EQ(errno, EPERM);
  EXPECT_EQ(chip.requested(), (std::set<unsigned>{5, 6}));
  EXPECT_EQ(chip.consumer(5), "bench");

  // The kernel frees a handle's lines when its descriptor closes.
  gpiod_line_release(out);
  EXPECT_EQ(chip.requested(), std::set<unsigned>{6});
  EXPECT_EQ(chip.levels()[5], 1);  // released lines keep their level
}

TEST(EmulatedGpioChip, VanishedChipAnswersEnodev) {
  if (!UmockdevBed::available()) GTEST_SKIP() << "not under umockdev-wrapper";
  UmockdevBed bed;
  EmulatedGpioChip chip(bed, chip_options("gpiochip0", 0, 4));
  ChipPtr open{gpiod_chip_open("/dev/gpiochip0")};
  ASSERT_TRUE(open) << std::strerror(errno);
  gpiod_line* line = gpiod_chip_get_line(open.get(), 1);
  ASSERT_TRUE(line);
  ASSERT_EQ(gpiod_line_request_output(line, "bench", 0), 0);
  chip.vanish_after(1);
  EXPECT_EQ(gpiod_line_set_value(line, 1), 0);
  EXPECT_TRUE(chip.vanished());
  EXPECT_EQ(gpiod_line_set_value(line, 0), -1);
  EXPECT_EQ(errno, ENODEV);
  EXPECT_EQ(chip.levels()[1], 1);
  EXPECT_EQ(gpiod_chip_open("/dev/gpiochip0"), nullptr);
}

}  // namespace
}  // namespace psrig::test
