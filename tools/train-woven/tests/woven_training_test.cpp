// The trainer works: from scratch, a few hundred steps on a small data set
// (the analytic stand-in, written and read through the real file) lower
// the loss below half its start; a resumed run ends where an unbroken one
// does; the weights it writes are what the runtime loads.

#include "woven_training.h"

#include <chrono>
#include <cmath>
#include <fstream>
#include <optional>

#include <gtest/gtest.h>

#include "psrig/cloth/weave_rules.h"
#include "psrig/cloth/woven_dataset_generator.h"
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

// The runtime's network from trained weights, with the data set's
// materials prepared (the decoder's inputs per material).
struct NetworkWithMaterials {
  cloth::WovenNetwork network;
  std::vector<cloth::WovenDecoderMaterial> materials;
};
std::optional<NetworkWithMaterials> network_with_materials(
    const cloth::WovenNetworkWeights& weights, const cloth::WovenDataset& dataset) {
  auto network = cloth::WovenNetwork::from_weights(weights);
  EXPECT_TRUE(network);
  if (!network) return std::nullopt;
  NetworkWithMaterials prepared{std::move(*network), {}};
  for (const cloth::WovenMaterialSample& material : dataset.materials) {
    auto decoder_material = prepared.network.prepare(material);
    EXPECT_TRUE(decoder_material);
    if (!decoder_material) return std::nullopt;
    prepared.materials.push_back(std::move(*decoder_material));
  }
  return prepared;
}

// How far the network's answer for a footprint is from the mean of its
// four quarters' (the sum of the four components), over the data set's
// first queries, relative to the answers' mean.
double quarter_inconsistency(const cloth::WovenNetworkWeights& weights,
                             const cloth::WovenDataset& dataset) {
  auto prepared = network_with_materials(weights, dataset);
  if (!prepared) return 1e9;
  const auto& [network, materials] = *prepared;
  auto f = [&](const cloth::WovenQuery& q, float du, float dv, float size) {
    const cloth::WovenComponents c =
        network.decode(materials[q.material], {q.u + du, q.v + dv, size, q.wi, q.wo});
    return static_cast<double>(c.c_warp + c.c_weft + c.s_warp + c.s_weft);
  };
  double gap = 0, total = 0;
  for (std::size_t i = 0; i < std::min<std::size_t>(dataset.queries.size(), 2000); ++i) {
    const cloth::WovenQuery& q = dataset.queries[i];
    const float d = q.size / 4;
    const double quarters =
        (f(q, -d, -d, 2 * d) + f(q, d, -d, 2 * d) + f(q, -d, d, 2 * d) + f(q, d, d, 2 * d)) / 4;
    gap += std::abs(f(q, 0, 0, q.size) - quarters);
    total += quarters;
  }
  return gap / std::max(total, 1e-9);
}

// On aggregates of a real twill and satin (the generator, a small grid),
// with the footprint's features: the consistency term leaves the loss
// halving and brings a footprint's answer nearer its quarters' mean than
// the same run without it.
Result<cloth::WovenDataset> small_twill_and_satin() {
  cloth::WovenDatasetOptions small;
  small.texture_size = 32;
  small.shapes_per_pattern = 1;
  small.appearances_per_shape = 1;
  small.centre_grid = 4;
  small.small_sizes = 4;
  small.large_sizes = 1;
  small.direction_grid = 2;
  small.samples = 256;
  return cloth::generate_woven_dataset({cloth::twill_weave(2, 2), cloth::satin_weave(5, 2)}, small,
                                       3);
}

TEST(WovenTraining, TheConsistencyTermHoldsAFootprintToItsQuarters) {
  auto dataset = small_twill_and_satin();
  ASSERT_TRUE(dataset) << dataset.error().describe();
  TrainingOptions options = short_run(400);
  options.shape.footprint_features = cloth::woven_footprint_feature_count;
  auto plain = train_woven_network(*dataset, options, "test");
  options.consistency = 20;
  auto held = train_woven_network(*dataset, options, "test");
  ASSERT_TRUE(plain && held);
  EXPECT_LT(held->final_loss, 0.5 * held->initial_loss);
  const double without = quarter_inconsistency(plain->weights, *dataset);
  const double with = quarter_inconsistency(held->weights, *dataset);
  std::printf(
      "a footprint against its quarters' mean: %.4f without the term, %.4f with "
      "(loss %.4f and %.4f)\n",
      without, with, plain->final_loss, held->final_loss);
  EXPECT_LT(with, 0.8 * without);
}

// The diffuse components' error (C_warp and C_weft) over the data set's
// first queries, relative to their mean.
double diffuse_error(const cloth::WovenNetworkWeights& weights,
                     const cloth::WovenDataset& dataset) {
  auto prepared = network_with_materials(weights, dataset);
  if (!prepared) return 1e9;
  const auto& [network, materials] = *prepared;
  double squared = 0, total = 0;
  const std::size_t count = std::min<std::size_t>(dataset.queries.size(), 2000);
  for (std::size_t i = 0; i < count; ++i) {
    const cloth::WovenQuery& q = dataset.queries[i];
    const cloth::WovenComponents c =
        network.decode(materials[q.material], {q.u, q.v, q.size, q.wi, q.wo});
    squared += std::pow(c.c_warp - q.c_warp, 2) + std::pow(c.c_weft - q.c_weft, 2);
    total += q.c_warp + q.c_weft;
  }
  return std::sqrt(squared / (2.0 * static_cast<double>(count))) /
         std::max(total / (2.0 * static_cast<double>(count)), 1e-9);
}

// With the paper's lambda_C the diffuse components, most of a woven's
// colour, weigh little in the loss; a larger one fits them closer.
TEST(WovenTraining, ALargerDiffuseWeightFitsTheDiffuseComponentsCloser) {
  auto dataset = small_twill_and_satin();
  ASSERT_TRUE(dataset) << dataset.error().describe();
  TrainingOptions options = short_run(800);
  auto paper = train_woven_network(*dataset, options, "test");
  options.diffuse_loss_weight = 4;
  auto weighted = train_woven_network(*dataset, options, "test");
  ASSERT_TRUE(paper && weighted);
  const double before = diffuse_error(paper->weights, *dataset);
  const double after = diffuse_error(weighted->weights, *dataset);
  std::printf(
      "the diffuse components' RMS error over their mean: %.4f with lambda_C 0.1, %.4f "
      "with 4\n",
      before, after);
  EXPECT_LT(after, 0.8 * before);
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
