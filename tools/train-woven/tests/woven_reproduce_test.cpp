// The shipped weights (config/woven/woven.wnn) come from a command anyone
// can run again. Retraining them takes minutes, more than a test may, so
// this checks the chain that makes them instead, bit for bit against a
// small committed fixture (woven_reproduce_fixture.txt): the generator's
// data set (chen2024's seven training weaves and the shipped 2/2 twill,
// with a material each at the far level's parameters, a small grid) from
// seed 1, then the trainer's first 40 steps from seed 1 on one thread
// with the shipped run's network and loss (footprint features, 8 bins,
// the consistency term, lambda_C 4), give the same losses and the same
// weights (an FNV-1a hash of every float) as when the fixture was
// written. The full retrain's commands are in config/woven/README.md.
//
// PSRIG_WRITE_REPRODUCE_FIXTURE=1 rewrites the fixture (after a deliberate
// change to the generator or the trainer; say why in the commit).

#include <bit>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "psrig/cloth/weave_matrix.h"
#include "psrig/cloth/weave_rules.h"
#include "psrig/cloth/woven_dataset_generator.h"
#include "psrig/cloth/woven_footprint_features.h"
#include "psrig/cloth/woven_network_weights.h"
#include "woven_training.h"

namespace psrig::train_woven {
namespace {

const std::filesystem::path kFixture =
    PSRIG_SOURCE_DIR "/tools/train-woven/tests/woven_reproduce_fixture.txt";
const std::filesystem::path kShippedWeights = PSRIG_SOURCE_DIR "/config/woven/woven.wnn";

void hash_floats(std::uint64_t& hash, const std::vector<float>& values) {
  for (const float value : values) {
    const auto bits = std::bit_cast<std::uint32_t>(value);
    for (int byte = 0; byte < 4; ++byte) {
      hash ^= (bits >> (8 * byte)) & 0xffu;
      hash *= 0x100000001b3ull;
    }
  }
}

std::uint64_t weights_hash(const cloth::WovenNetworkWeights& w) {
  std::uint64_t hash = 0xcbf29ce484222325ull;
  for (const auto& conv : w.conv) {
    hash_floats(hash, conv.weight);
    hash_floats(hash, conv.bias);
  }
  for (const cloth::DenseLayer* layer :
       {&w.enc_in, &w.enc_res1, &w.enc_res2, &w.enc_out, &w.fuse1, &w.fuse2, &w.ang_in, &w.ang_res1,
        &w.ang_res2, &w.ang_mid, &w.ang_out}) {
    hash_floats(hash, layer->weight);
    hash_floats(hash, layer->bias);
  }
  return hash;
}

std::string fixture_text(const TrainingResult& result) {
  std::ostringstream text;
  text << "# woven_reproduce_test.cpp's expectations: losses as hex floats, the weights' FNV-1a\n";
  text << "initial_loss " << std::hexfloat << result.initial_loss << '\n';
  text << "final_loss " << std::hexfloat << result.final_loss << '\n';
  text << "weights_fnv1a " << std::hex << weights_hash(result.weights) << '\n';
  return text.str();
}

TEST(WovenReproduce, TheGeneratorAndTheFirstStepsGiveTheCommittedFixtureBitForBit) {
  cloth::WovenDatasetOptions small;
  small.shapes_per_pattern = 1;
  small.appearances_per_shape = 1;
  small.centre_grid = 2;
  small.direction_grid = 2;
  small.samples = 256;
  small.default_appearance = true;
  std::vector<cloth::WeaveMatrix> weaves = cloth::chen2024_training_weaves();
  auto twill = cloth::load_weave_matrix(PSRIG_SOURCE_DIR "/config/patterns/twill-2x2.weave");
  ASSERT_TRUE(twill) << twill.error().describe();
  weaves.push_back(*twill);
  auto dataset = cloth::generate_woven_dataset(weaves, small, 1);
  ASSERT_TRUE(dataset) << dataset.error().describe();
  TrainingOptions options;  // the shipped run's, but for the steps
  options.shape.blob_bins = 8;
  options.shape.fusion_width = 32;
  options.shape.footprint_features = cloth::woven_footprint_feature_count;
  options.consistency = 1;
  options.diffuse_loss_weight = 4;
  options.steps = 40;
  options.seed = 1;
  options.threads = 1;
  options.progress = false;
  auto result = train_woven_network(*dataset, options, "woven_reproduce_test");
  ASSERT_TRUE(result) << result.error().describe();
  const std::string got = fixture_text(*result);
  if (std::getenv("PSRIG_WRITE_REPRODUCE_FIXTURE") != nullptr) {
    std::ofstream(kFixture) << got;
    GTEST_SKIP() << "wrote " << kFixture;
  }
  std::ifstream in(kFixture);
  ASSERT_TRUE(in) << kFixture;
  std::stringstream expected;
  expected << in.rdbuf();
  EXPECT_EQ(got, expected.str());
}

TEST(WovenReproduce, TheShippedWeightsRecordTheCommandThatMadeThem) {
  auto weights = cloth::read_woven_network(kShippedWeights);
  ASSERT_TRUE(weights) << weights.error().describe();
  EXPECT_TRUE(weights->command.starts_with("psrig-train-woven ")) << weights->command;
  EXPECT_NE(weights->command.find("--seed " + std::to_string(weights->seed)), std::string::npos)
      << weights->command;
  EXPECT_NE(weights->command.find("--steps " + std::to_string(weights->steps)), std::string::npos)
      << weights->command;
  EXPECT_NE(weights->command.find("--threads"), std::string::npos) << weights->command;
}

}  // namespace
}  // namespace psrig::train_woven
