// ScratchDirectory: private, under $TMPDIR, gone with the object (and only
// once: a moved-from one removes nothing).

#include "psrig/formats/scratch_directory.h"

#include <cstdlib>
#include <fstream>

#include <gtest/gtest.h>

#include "test_support.h"

namespace psrig {
namespace {

namespace fs = std::filesystem;

TEST(ScratchDirectory, LivesUnderTmpdirAndGoesWithItsFiles) {
  test::TempDir root("psrig-scratch-test");
  const char* saved = std::getenv("TMPDIR");
  const std::string previous = saved ? saved : "";
  ::setenv("TMPDIR", root.path().c_str(), 1);
  fs::path where;
  {
    auto scratch = formats::ScratchDirectory::create("tile");
    ASSERT_TRUE(scratch) << scratch.error().describe();
    where = scratch->path();
    EXPECT_EQ(where.parent_path(), root.path());
    EXPECT_EQ(where.filename().string().rfind("psrig-tile-", 0), 0U) << where;
    EXPECT_EQ(fs::status(where).permissions() & fs::perms::others_all, fs::perms::none);
    fs::create_directories(where / "tile");
    std::ofstream(where / "tile" / "tile.json") << "{}";
    formats::ScratchDirectory moved(std::move(*scratch));  // the old one removes nothing
    EXPECT_TRUE(fs::exists(where / "tile" / "tile.json"));
  }
  EXPECT_FALSE(fs::exists(where));
  EXPECT_TRUE(test::list_directory(root.path()).empty());

  ::setenv("TMPDIR", (root.path() / "missing").c_str(), 1);
  const auto refused = formats::ScratchDirectory::create("tile");
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().describe().find("TMPDIR"), std::string::npos)
      << refused.error().describe();
  if (saved)
    ::setenv("TMPDIR", previous.c_str(), 1);
  else
    ::unsetenv("TMPDIR");
}

}  // namespace
}  // namespace psrig
