// The trainer works: from scratch, a few hundred steps on a small data set
// (the analytic stand-in, written and read through the real file) lower
// the loss below half its start; a resumed run ends where an unbroken one
// does; the weights it writes are what the runtime loads.

#include "woven_training.h"

#include <chrono>
#include <fstream>

#include <gtest/gtest.h>

#include "psrig/cloth/woven_network.h"
#include "test_support.h"
#include "woven_standin.h"

namespace psrig::train_woven {
namespace {

cloth::WovenDataset stand_in_through_the_file(const test::TempDir& dir) {
  const auto file = dir / "standin.wds";
  EXPECT_TRUE(cloth::write_woven_dataset(file, test::analytic_woven_dataset(8, 600, 24, 21)));
  auto read = cloth::read_woven_dataset(file);
  EXPECT_TRUE(read) << read.error().describe();
  return read ? *read : cloth::WovenDataset{};
}

TrainingOptions short_run(std::int64_t steps) {
  TrainingOptions options;
  options.steps = steps;
  options.batch = 256;
  options.learning_rate = 3e-3;
  options.seed = 4;
  options.progress = false;
  return options;
}

TEST(WovenTraining, AFewHundredStepsHalveTheLoss) {
  test::TempDir dir;
  const cloth::WovenDataset dataset = stand_in_through_the_file(dir);
  const auto start = std::chrono::steady_clock::now();
  auto trained = train_woven_network(dataset, short_run(400), "test");
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_TRUE(trained) << trained.error().describe();
  RecordProperty("initial_loss", std::to_string(trained->initial_loss));
  RecordProperty("final_loss", std::to_string(trained->final_loss));
  std::printf("loss %.5f -> %.5f in %.1f s (400 steps of 256)\n", trained->initial_loss,
              trained->final_loss, seconds);
  EXPECT_LT(trained->final_loss, 0.5 * trained->initial_loss);

  // What it writes, the runtime loads, with the record of what made it.
  ASSERT_TRUE(cloth::write_woven_network(dir / "net.wnn", trained->weights));
  auto network = cloth::WovenNetwork::load(dir / "net.wnn");
  ASSERT_TRUE(network) << network.error().describe();
  EXPECT_EQ(network->weights().steps, 400U);
  EXPECT_EQ(network->weights().seed, 4U);
  EXPECT_EQ(network->weights().command, "test");
}

TEST(WovenTraining, AResumedRunEndsWhereAnUnbrokenOneDoes) {
  test::TempDir dir;
  const cloth::WovenDataset dataset = stand_in_through_the_file(dir);
  auto unbroken = train_woven_network(dataset, short_run(40), "test");
  ASSERT_TRUE(unbroken) << unbroken.error().describe();

  // Stopped half way through the 40-step run (its learning-rate schedule),
  // then resumed from the checkpoint.
  TrainingOptions first = short_run(40);
  first.checkpoint = dir / "run.checkpoint";
  first.checkpoint_every = 20;
  first.stop_at = 20;
  TrainingOptions second = first;
  second.stop_at = 0;
  second.resume = true;
  ASSERT_TRUE(train_woven_network(dataset, first, "test"));
  ASSERT_TRUE(std::filesystem::exists(first.checkpoint));
  auto resumed = train_woven_network(dataset, second, "test");
  ASSERT_TRUE(resumed) << resumed.error().describe();
  EXPECT_EQ(resumed->resumed_at, 20);
  EXPECT_EQ(resumed->weights.ang_out.weight, unbroken->weights.ang_out.weight);
  EXPECT_EQ(resumed->weights.conv[0].weight, unbroken->weights.conv[0].weight);
  EXPECT_EQ(resumed->final_loss, unbroken->final_loss);
}

TEST(WovenTraining, AForeignCheckpointIsRefused) {
  test::TempDir dir;
  const cloth::WovenDataset dataset = stand_in_through_the_file(dir);
  TrainingOptions options = short_run(2);
  options.checkpoint = dir / "other.checkpoint";
  options.resume = true;
  { std::ofstream(options.checkpoint) << "not a checkpoint"; }
  auto trained = train_woven_network(dataset, options, "test");
  ASSERT_FALSE(trained);
  EXPECT_EQ(trained.error().file, options.checkpoint);
}

}  // namespace
}  // namespace psrig::train_woven
