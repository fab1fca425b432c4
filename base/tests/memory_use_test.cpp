// The memory figures report.json carries: a sampler's peak follows what was
// touched, and starts afresh when taken; the process's peak covers it.

#include "psrig/base/memory_use.h"

#include <cstring>
#include <memory>
#include <thread>

#include <gtest/gtest.h>

namespace psrig {
namespace {

constexpr std::size_t kMb = std::size_t{1} << 20;

TEST(MemoryUse, ASamplersPeakFollowsWhatWasTouchedAndStartsAfreshWhenTaken) {
  if (resident_bytes() == 0) GTEST_SKIP() << "no /proc/self here";
  ResidentSampler sampler(std::chrono::milliseconds(1));
  const std::size_t before = resident_bytes();
  {
    const auto block = std::make_unique<char[]>(96 * kMb);
    std::memset(block.get(), 1, 96 * kMb);  // touched: resident
    EXPECT_GE(resident_bytes(), before + 90 * kMb);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));  // seen by the sampler
  }
  EXPECT_GE(sampler.take_peak(), before + 90 * kMb);  // freed, but it was the peak
  EXPECT_LT(sampler.take_peak(), before + 48 * kMb);  // afresh
  EXPECT_GE(peak_resident_bytes(), before + 90 * kMb);
}

}  // namespace
}  // namespace psrig
