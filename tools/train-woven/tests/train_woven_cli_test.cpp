// psrig-train-woven as a user runs it: a data set file in, weights out
// with the command that made them, a checkpoint it resumes from, and a
// bad data set named with what is wrong.

#include <fstream>

#include <gtest/gtest.h>

#include "psrig/cloth/woven_network.h"
#include "test_support.h"
#include "woven_standin.h"

namespace psrig::train_woven {
namespace {

using test::contains;

TEST(TrainWovenCli, TrainsResumesAndWritesWeightsTheRuntimeLoads) {
  test::TempDir dir;
  const auto dataset = dir / "set.wds";
  ASSERT_TRUE(cloth::write_woven_dataset(dataset, test::analytic_woven_dataset(4, 200, 16, 2)));
  const auto weights = (dir / "net.wnn").string();
  const test::ProgramRun first =
      test::run_program("psrig-train-woven", {dataset.string(), "-o", weights, "--steps", "30",
                                              "--stop-at", "15", "--batch", "64", "--seed", "9"});
  ASSERT_EQ(first.exit_code, 0) << first.err;
  EXPECT_TRUE(contains(first.err, "4 materials, 800 queries")) << first.err;
  EXPECT_TRUE(contains(first.err, "step 15/15")) << first.err;  // the progress bar
  EXPECT_TRUE(std::filesystem::exists(weights + ".checkpoint"));

  const test::ProgramRun second =
      test::run_program("psrig-train-woven", {dataset.string(), "-o", weights, "--steps", "30",
                                              "--batch", "64", "--seed", "9", "--resume"});
  ASSERT_EQ(second.exit_code, 0) << second.err;
  EXPECT_TRUE(contains(second.err, "(resumed)")) << second.err;
  auto network = cloth::WovenNetwork::load(weights);
  ASSERT_TRUE(network) << network.error().describe();
  EXPECT_EQ(network->weights().steps, 30U);
  EXPECT_EQ(network->weights().seed, 9U);
  EXPECT_TRUE(contains(network->weights().command, "--resume")) << network->weights().command;
}

TEST(TrainWovenCli, ABadDataSetIsNamedWithWhatIsWrong) {
  test::TempDir dir;
  { std::ofstream(dir / "bad.wds") << "psrig-woven-dataset/1\nshort"; }
  const test::ProgramRun run = test::run_program(
      "psrig-train-woven", {(dir / "bad.wds").string(), "-o", (dir / "net.wnn").string()});
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_TRUE(contains(run.err, "bad.wds")) << run.err;
  EXPECT_TRUE(contains(run.err, "the file ends inside the seed")) << run.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "net.wnn"));
}

// psrig-woven-probe on the shipped weights and plain weave, at a coarse
// grid: a line for each footprint size and eye; a weights file that is
// not there is named.
TEST(WovenProbeCli, ProbesTheShippedWeightsAndNamesAMissingFile) {
  const std::filesystem::path source(PSRIG_SOURCE_DIR);
  const std::string plain = (source / "config/patterns/plain.weave").string();
  const test::ProgramRun run = test::run_program(
      "psrig-woven-probe", {plain, "--weights", (source / "config/woven/woven.wnn").string(),
                            "--centre-grid", "2", "--samples", "64"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(contains(run.out, "plain weave")) << run.out;
  EXPECT_TRUE(contains(run.out, "0.10  head-on")) << run.out;
  EXPECT_TRUE(contains(run.out, "1.50  eye 34.75,-52.1")) << run.out;
  test::TempDir dir;
  const std::string absent = (dir / "absent.wnn").string();
  const test::ProgramRun missing =
      test::run_program("psrig-woven-probe", {plain, "--weights", absent});
  EXPECT_NE(missing.exit_code, 0) << missing.err;
  EXPECT_TRUE(contains(missing.err, "absent.wnn")) << missing.err;
}

}  // namespace
}  // namespace psrig::train_woven
