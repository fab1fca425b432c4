// The woven data set file: what is written reads back bit for bit, and a
// damaged file is refused naming the file and what is wrong, never read
// as something else.

#include "psrig/cloth/woven_dataset.h"

#include <fstream>

#include <gtest/gtest.h>

#include "test_support.h"
#include "woven_standin.h"

namespace psrig::cloth {
namespace {

namespace fs = std::filesystem;

std::vector<char> file_bytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void put_bytes(const fs::path& file, const std::vector<char>& bytes) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// The error's text when reading `bytes` as a data set fails (empty if it reads).
std::string read_failure(const test::TempDir& dir, const std::vector<char>& bytes) {
  const fs::path file = dir / "damaged.wds";
  put_bytes(file, bytes);
  auto read = read_woven_dataset(file);
  return read ? std::string() : read.error().describe();
}

TEST(WovenDataset, RoundTripsEveryField) {
  test::TempDir dir;
  WovenDataset written = test::analytic_woven_dataset(3, 50, 12, 7);
  written.materials[1].twist_deg = -30;
  written.materials[1].inclination_deg = 27.5F;
  const fs::path file = dir / "set.wds";
  ASSERT_TRUE(write_woven_dataset(file, written));
  EXPECT_FALSE(fs::exists(dir / "set.wds.tmp"));

  auto read = read_woven_dataset(file);
  ASSERT_TRUE(read) << read.error().describe();
  EXPECT_EQ(read->seed, written.seed);
  EXPECT_EQ(read->command, written.command);
  ASSERT_EQ(read->materials.size(), written.materials.size());
  for (std::size_t m = 0; m < written.materials.size(); ++m) {
    const WovenMaterialSample &a = written.materials[m], &b = read->materials[m];
    EXPECT_EQ(a.pattern, b.pattern);
    EXPECT_EQ(a.texture_size, b.texture_size);
    EXPECT_EQ(a.normal, b.normal);
    EXPECT_EQ(a.orientation, b.orientation);
    EXPECT_EQ(a.roughness, b.roughness);
    EXPECT_EQ(a.height_scale, b.height_scale);
    EXPECT_EQ(a.twist_deg, b.twist_deg);
    EXPECT_EQ(a.inclination_deg, b.inclination_deg);
  }
  ASSERT_EQ(read->queries.size(), written.queries.size());
  for (std::size_t q = 0; q < written.queries.size(); ++q) {
    const WovenQuery &a = written.queries[q], &b = read->queries[q];
    EXPECT_EQ(a.material, b.material);
    EXPECT_EQ(a.u, b.u);
    EXPECT_EQ(a.v, b.v);
    EXPECT_EQ(a.size, b.size);
    EXPECT_EQ(a.wi, b.wi);
    EXPECT_EQ(a.wo, b.wo);
    EXPECT_EQ(a.c_warp, b.c_warp);
    EXPECT_EQ(a.c_weft, b.c_weft);
    EXPECT_EQ(a.s_warp, b.s_warp);
    EXPECT_EQ(a.s_weft, b.s_weft);
  }
}

TEST(WovenDataset, AnEmptySetRoundTrips) {
  test::TempDir dir;
  ASSERT_TRUE(write_woven_dataset(dir / "empty.wds", WovenDataset{}));
  auto read = read_woven_dataset(dir / "empty.wds");
  ASSERT_TRUE(read) << read.error().describe();
  EXPECT_TRUE(read->materials.empty());
  EXPECT_TRUE(read->queries.empty());
}

TEST(WovenDataset, RefusesToWriteWhatItCouldNotReadBack) {
  test::TempDir dir;
  WovenDataset bad = test::analytic_woven_dataset(1, 4, 8, 1);
  bad.queries[2].material = 5;
  auto wrote = write_woven_dataset(dir / "bad.wds", bad);
  ASSERT_FALSE(wrote);
  EXPECT_NE(wrote.error().message.find("query 2 names material 5 of 1"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "bad.wds"));

  bad = test::analytic_woven_dataset(1, 4, 8, 1);
  bad.materials[0].normal.pop_back();
  EXPECT_FALSE(write_woven_dataset(dir / "bad.wds", bad));
  EXPECT_FALSE(fs::exists(dir / "bad.wds"));
}

TEST(WovenDataset, AFailedWriteKeepsTheOldFile) {
  test::TempDir dir;
  const WovenDataset good = test::analytic_woven_dataset(1, 4, 8, 1);
  ASSERT_TRUE(write_woven_dataset(dir / "set.wds", good));
  WovenDataset bad = good;
  bad.queries[0].material = 9;
  EXPECT_FALSE(write_woven_dataset(dir / "set.wds", bad));
  EXPECT_TRUE(read_woven_dataset(dir / "set.wds"));
}

class DamagedDataset : public testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(write_woven_dataset(dir / "set.wds", test::analytic_woven_dataset(2, 10, 8, 3)));
    bytes = file_bytes(dir / "set.wds");
  }
  test::TempDir dir;
  std::vector<char> bytes;
};

TEST_F(DamagedDataset, EveryTruncationIsRefusedNamingTheFile) {
  // Cut anywhere (not only at the end of a record): nothing reads.
  for (std::size_t size = 0; size < bytes.size(); size += 37) {
    const std::string failure = read_failure(
        dir, std::vector<char>(bytes.begin(), bytes.begin() + static_cast<long>(size)));
    ASSERT_FALSE(failure.empty()) << "cut at " << size;
    EXPECT_NE(failure.find("damaged.wds"), std::string::npos) << failure;
  }
  std::vector<char> one_short(bytes.begin(), bytes.end() - 1);
  EXPECT_NE(read_failure(dir, one_short).find("says 20 queries"), std::string::npos)
      << read_failure(dir, one_short);
}

TEST_F(DamagedDataset, TrailingBytesAreRefused) {
  std::vector<char> longer = bytes;
  longer.insert(longer.end(), 56, '\0');  // one query record too many
  EXPECT_NE(read_failure(dir, longer).find("says 20 queries"), std::string::npos)
      << read_failure(dir, longer);
}

TEST_F(DamagedDataset, AnotherFileIsNotTakenForADataSet) {
  std::vector<char> other = bytes;
  other[6] = 'X';
  EXPECT_NE(read_failure(dir, other).find("not a psrig-woven-dataset/1 file"), std::string::npos);
  EXPECT_NE(read_failure(dir, {}).find("not a psrig-woven-dataset/1 file"), std::string::npos);
}

TEST_F(DamagedDataset, AHugeCountIsRefusedBeforeAnythingIsAllocated) {
  // The material count sits after the magic (22), the seed (8) and the command.
  const std::size_t command_size = static_cast<unsigned char>(bytes[30]);
  std::vector<char> huge = bytes;
  const std::size_t texture_size_at = 22 + 8 + 4 + command_size + 4 + 4 + 5;  // "plain"
  const std::uint32_t big = 4000;
  std::memcpy(huge.data() + texture_size_at, &big, 4);
  EXPECT_NE(read_failure(dir, huge).find("material 0's normal texture says 48000000 floats"),
            std::string::npos)
      << read_failure(dir, huge);
  const std::uint32_t too_big = 5000;
  std::memcpy(huge.data() + texture_size_at, &too_big, 4);
  EXPECT_NE(read_failure(dir, huge).find("texture size is 5000"), std::string::npos);
}

TEST_F(DamagedDataset, AQueryOnAMissingMaterialIsRefused) {
  std::vector<char> wrong = bytes;
  const std::uint32_t material = 2;
  std::memcpy(wrong.data() + wrong.size() - 56, &material, 4);  // the last query's
  EXPECT_NE(read_failure(dir, wrong).find("query 19 names material 2 of 2"), std::string::npos)
      << read_failure(dir, wrong);
}

TEST_F(DamagedDataset, ANotFiniteTargetIsRefused) {
  std::vector<char> wrong = bytes;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(wrong.data() + wrong.size() - 4, &nan, 4);
  EXPECT_NE(read_failure(dir, wrong).find("query 19 holds a value that is not finite"),
            std::string::npos);
}

TEST(WovenDataset, AMissingFileIsAnIoError) {
  auto read = read_woven_dataset("/nonexistent/set.wds");
  ASSERT_FALSE(read);
  EXPECT_EQ(read.error().kind, ErrorKind::io);
  EXPECT_EQ(read.error().file, fs::path("/nonexistent/set.wds"));
}

}  // namespace
}  // namespace psrig::cloth
