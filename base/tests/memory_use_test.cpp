// The memory figures report.json carries: the peak follows what was touched,
// and starts afresh when reset.

#include "psrig/base/memory_use.h"

#include <cstring>
#include <memory>

#include <gtest/gtest.h>

namespace psrig {
namespace {

constexpr std::size_t kMb = std::size_t{1} << 20;

TEST(MemoryUse, ThePeakFollowsWhatWasTouchedAndStartsAfreshWhenReset) {
  if (resident_bytes() == 0) GTEST_SKIP() << "no /proc/self/status here";
  if (!reset_peak_resident()) GTEST_SKIP() << "/proc/self/clear_refs refused";
  const std::size_t before = resident_bytes();
  EXPECT_LE(peak_resident_bytes(), before + 8 * kMb);
  {
    const auto block = std::make_unique<char[]>(96 * kMb);
    std::memset(block.get(), 1, 96 * kMb);  // touched: resident
    EXPECT_GE(resident_bytes(), before + 90 * kMb);
  }
  EXPECT_GE(peak_resident_bytes(), before + 90 * kMb);  // freed, but it was the peak
  ASSERT_TRUE(reset_peak_resident());
  EXPECT_LT(peak_resident_bytes(), before + 48 * kMb);
}

}  // namespace
}  // namespace psrig
