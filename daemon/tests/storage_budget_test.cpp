// The storage budget: a scan that would not fit is refused before any LED
// goes on, by what the configuration says a scan takes or what the last
// one took, whichever is more; the message says how much is free and what
// to do.

#include "psrig/daemon/storage_budget.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "test_support.h"

namespace psrig::daemon {
namespace {

namespace fs = std::filesystem;

config::RigConfig camera_of(int width, int height) {
  config::RigConfig config;
  config.camera.backend = "v4l2";
  config.camera.width = width;
  config.camera.height = height;
  return config;
}

TEST(StorageBudget, ASmallScanFits) {
  test::TempDir root;
  StorageBudget budget(root.path());
  EXPECT_TRUE(budget.check(camera_of(640, 480)));
}

TEST(StorageBudget, AScanLargerThanTheDiskIsRefusedSayingWhatIsFree) {
  test::TempDir root;
  StorageBudget budget(root.path());
  const auto free = fs::space(root.path()).available;
  // A camera whose frames alone would take more than the disk has.
  const int side = static_cast<int>(std::min<double>(65535, std::sqrt(free / 8.0) + 1024));
  auto config = camera_of(side, side);
  config.lights.channels = 16;
  if (free > static_cast<std::uintmax_t>(side) * side * 17 * 6)
    GTEST_SKIP() << "this disk is larger than the largest scan rig.toml can describe";
  auto refused = budget.check(config);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().kind, ErrorKind::io);
  EXPECT_NE(refused.error().message.find("free"), std::string::npos) << refused.error().message;
  EXPECT_NE(refused.error().message.find("LEDs not switched on"), std::string::npos);
  EXPECT_EQ(refused.error().file, root.path());
}

TEST(StorageBudget, TheLastScanSetsTheBudgetWhenTheCameraSizeIsUnknown) {
  test::TempDir root;
  StorageBudget budget(root.path());
  const auto config = camera_of(0, 0);  // the camera's own size: known only once it scanned
  EXPECT_TRUE(budget.check(config));
  // A scan whose (sparse) frame is larger than the free space.
  const fs::path scan = root / "scan";
  fs::create_directories(scan / "maps");
  { std::ofstream(scan / "led0.png") << "x"; }
  const auto free = fs::space(root.path()).available;
  fs::resize_file(scan / "led0.png", free + (std::uintmax_t{1} << 30));
  budget.record_scan(scan, scan / "maps");
  EXPECT_FALSE(budget.check(config));
  // A smaller scan after it lowers the budget again.
  fs::resize_file(scan / "led0.png", 1 << 20);
  budget.record_scan(scan, scan / "maps");
  EXPECT_TRUE(budget.check(config));
}

TEST(StorageBudget, AMissingRootIsAnIoErrorNamingIt) {
  StorageBudget budget("/nonexistent/psrig-storage");
  auto refused = budget.check(camera_of(640, 480));
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().file, "/nonexistent/psrig-storage");
}

}  // namespace
}  // namespace psrig::daemon
