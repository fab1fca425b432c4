// AtomicDirectory's staging names: the one place that spells them also
// reads them back, for those (the daemon's catalogue) that clean up what a
// killed writer left.

#include "psrig/formats/atomic_directory.h"

#include <unistd.h>

#include <gtest/gtest.h>

#include "test_support.h"

namespace psrig::processing {
namespace {

namespace fs = std::filesystem;

TEST(AtomicDirectory, ItsStagingDirectoryNamesItsTargetAndItsWriter) {
  test::TempDir temp;
  auto directory = formats::AtomicDirectory::create(temp / "20261124-120000-swatch");
  ASSERT_TRUE(directory) << directory.error().describe();
  const auto staging = formats::AtomicDirectory::parse_staging(directory->path());
  ASSERT_TRUE(staging) << directory->path();
  EXPECT_EQ(staging->target, "20261124-120000-swatch");
  EXPECT_EQ(staging->writer, ::getpid());
  // The target itself is not a staging directory.
  EXPECT_FALSE(formats::AtomicDirectory::parse_staging(directory->target()));
}

TEST(AtomicDirectory, StagingNamesAreReadBackWholeOrNotAtAll) {
  const auto maps = formats::AtomicDirectory::parse_staging("/data/scan/.maps.partial-4242-123456");
  ASSERT_TRUE(maps);
  EXPECT_EQ(maps->target, "maps");
  EXPECT_EQ(maps->writer, 4242);
  // A target whose own name holds the mark is read from the last one.
  const auto odd = formats::AtomicDirectory::parse_staging(".a.partial-1-2.partial-77-9");
  ASSERT_TRUE(odd);
  EXPECT_EQ(odd->target, "a.partial-1-2");
  EXPECT_EQ(odd->writer, 77);

  for (const char* name :
       {"maps", "scan.json", ".maps", ".maps.partial-", ".maps.partial-12", ".maps.partial-12-",
        ".maps.partial--5", ".maps.partial-0-5", ".maps.partial-x1-5", ".maps.partial-12-5x",
        "maps.partial-12-5", "..partial-12-5", ".maps.partial-99999999999-5"})
    EXPECT_FALSE(formats::AtomicDirectory::parse_staging(name)) << name;
}

}  // namespace
}  // namespace psrig::processing
