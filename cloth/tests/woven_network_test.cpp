// The woven network's weights file and its CPU runtime: the file round
// trips and refuses other networks' files; the decoder's per-material
// folding changes nothing; the one-blob encoding is periodic in u and v;
// the encoder sees the pattern and (alpha, beta). Its match with libtorch's
// forward pass is tested with the trainer (tools/train-woven/tests).

#include "psrig/cloth/woven_network.h"

#include <cmath>
#include <fstream>

#include <gtest/gtest.h>

#include "test_support.h"
#include "woven_standin.h"

namespace psrig::cloth {
namespace {

namespace fs = std::filesystem;

WovenNetworkWeights seeded_weights(std::uint64_t seed = 11) {
  auto weights = random_woven_network(WovenNetworkShape{}, seed);
  EXPECT_TRUE(weights) << weights.error().describe();
  return *weights;
}

TEST(WovenNetworkWeights, RoundTripsAndStaysSmall) {
  test::TempDir dir;
  WovenNetworkWeights written = seeded_weights();
  written.command = "psrig-train-woven set.wds --seed 3";
  written.steps = 1234;
  written.final_loss = 0.01F;
  ASSERT_TRUE(write_woven_network(dir / "net.wnn", written));
  EXPECT_LT(fs::file_size(dir / "net.wnn"), 5U << 20);  // the paper's 5 MB

  auto read = read_woven_network(dir / "net.wnn");
  ASSERT_TRUE(read) << read.error().describe();
  EXPECT_EQ(read->shape, written.shape);
  EXPECT_EQ(read->command, written.command);
  EXPECT_EQ(read->seed, written.seed);
  EXPECT_EQ(read->steps, 1234U);
  EXPECT_EQ(read->final_loss, 0.01F);
  EXPECT_EQ(read->conv[1].weight, written.conv[1].weight);
  EXPECT_EQ(read->enc_res2.bias, written.enc_res2.bias);
  EXPECT_EQ(read->fuse1.weight, written.fuse1.weight);
  EXPECT_EQ(read->ang_out.weight, written.ang_out.weight);
  EXPECT_EQ(read->ang_out.inputs, written.shape.angular_width);
}

// A network that takes the footprint's features is written as /2, with
// the count, and read back whole; a /1 file stays as it was.
TEST(WovenNetworkWeights, ANetworkWithFootprintFeaturesRoundTripsAsVersionTwo) {
  test::TempDir dir;
  WovenNetworkShape shape;
  shape.footprint_features = woven_footprint_feature_count;
  auto written = random_woven_network(shape, 5);
  ASSERT_TRUE(written);
  ASSERT_TRUE(write_woven_network(dir / "net.wnn", *written));
  ASSERT_TRUE(write_woven_network(dir / "plain.wnn", seeded_weights()));
  auto magic = [&](const char* name) {
    std::ifstream in(dir / name, std::ios::binary);
    std::string line;
    std::getline(in, line);
    return line;
  };
  EXPECT_EQ(magic("net.wnn"), "psrig-woven-net/2");
  EXPECT_EQ(magic("plain.wnn"), "psrig-woven-net/1");
  auto read = read_woven_network(dir / "net.wnn");
  ASSERT_TRUE(read) << read.error().describe();
  EXPECT_EQ(read->shape, shape);
  EXPECT_EQ(read->fuse1.inputs, shape.latent_size + 3 * shape.blob_bins + 12);
  EXPECT_EQ(read->fuse1.weight, written->fuse1.weight);

  shape.footprint_features = 8;  // not the features' count
  auto refused = random_woven_network(shape, 5);
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().describe().find("8 footprint features, not 0 or 12"), std::string::npos)
      << refused.error().describe();
}

TEST(WovenNetworkWeights, RefusesDamagedAndForeignFiles) {
  test::TempDir dir;
  ASSERT_TRUE(write_woven_network(dir / "net.wnn", seeded_weights()));
  std::ifstream in(dir / "net.wnn", std::ios::binary);
  const std::vector<char> bytes{std::istreambuf_iterator<char>(in),
                                std::istreambuf_iterator<char>()};
  auto failure = [&](std::vector<char> damaged) {
    std::ofstream(dir / "bad.wnn", std::ios::binary | std::ios::trunc)
        .write(damaged.data(), static_cast<std::streamsize>(damaged.size()));
    auto read = read_woven_network(dir / "bad.wnn");
    return read ? std::string() : read.error().describe();
  };
  EXPECT_NE(failure({bytes.begin(), bytes.end() - 3}).find("ang_out's biases"), std::string::npos);
  std::vector<char> longer = bytes;
  longer.push_back(0);
  EXPECT_NE(failure(longer).find("1 bytes after the last layer"), std::string::npos);
  EXPECT_NE(failure({bytes.begin(), bytes.begin() + 10}).find("not a psrig-woven-net/1 file"),
            std::string::npos);
  // The angular width changed in the header: the first layer that differs is named.
  std::vector<char> other = bytes;
  const std::uint32_t wider = 36;
  std::memcpy(other.data() + 18 + 8 * 4, &wider, 4);
  EXPECT_NE(failure(other).find("layer \"ang_in\" 32 x 37 (kernel 1) where the shape wants "
                                "\"ang_in\" 36 x 37"),
            std::string::npos)
      << failure(other);
  const std::uint32_t odd = 30;  // not a multiple of 4
  std::memcpy(other.data() + 18 + 8 * 4, &odd, 4);
  EXPECT_NE(failure(other).find("multiples of 4"), std::string::npos) << failure(other);
  EXPECT_FALSE(WovenNetwork::load(dir / "missing.wnn"));
}

TEST(WovenNetwork, FoldingTheLatentIntoTheFusionBiasChangesNothing) {
  auto network = WovenNetwork::from_weights(seeded_weights());
  ASSERT_TRUE(network);
  const WovenNetworkWeights& w = network->weights();
  const WovenMaterialSample material = test::analytic_woven_material(1, 24, 0.3F, 1.0F);
  auto latent = network->encode(material);
  ASSERT_TRUE(latent) << latent.error().describe();
  ASSERT_EQ(latent->size(), 64U);
  const WovenDecoderMaterial prepared = network->prepare(*latent, material);

  // fuse1 over [latent, blob] in full, against the folded bias plus the blob's share.
  std::vector<float> input(*latent);
  std::vector<float> blob(static_cast<std::size_t>(decoder_blob_inputs(w.shape)));
  one_blob_footprint(0.3F, 0.7F, 1.5F, w.shape.blob_bins, blob);
  input.insert(input.end(), blob.begin(), blob.end());
  for (int o = 0; o < w.fuse1.outputs; ++o) {
    double full = w.fuse1.bias[o], folded = prepared.fusion_bias[o];
    for (int i = 0; i < w.fuse1.inputs; ++i) {
      full += w.fuse1.weight[o * w.fuse1.inputs + i] * input[i];
      if (i >= w.shape.latent_size) {
        folded += w.fuse1.weight[o * w.fuse1.inputs + i] * input[i];
      }
    }
    EXPECT_NEAR(full, folded, 1e-4);
  }
}

TEST(WovenNetwork, TheEncoderSeesThePatternAndTheParameters) {
  auto network = WovenNetwork::from_weights(seeded_weights());
  ASSERT_TRUE(network);
  auto latent = [&](const WovenMaterialSample& m) { return *network->encode(m); };
  const auto plain = latent(test::analytic_woven_material(0, 24, 0.3F, 1.0F));
  EXPECT_EQ(plain, latent(test::analytic_woven_material(0, 24, 0.3F, 1.0F)));  // deterministic
  auto distance = [](const std::vector<float>& a, const std::vector<float>& b) {
    double sum = 0;
    for (std::size_t i = 0; i < a.size(); ++i)
      sum += (a[i] - b[i]) * (a[i] - b[i]);
    return std::sqrt(sum);
  };
  EXPECT_GT(distance(plain, latent(test::analytic_woven_material(3, 24, 0.3F, 1.0F))), 1e-3);
  EXPECT_GT(distance(plain, latent(test::analytic_woven_material(0, 24, 0.8F, 1.0F))), 1e-3);
  EXPECT_GT(distance(plain, latent(test::analytic_woven_material(0, 24, 0.3F, 0.2F))), 1e-3);
  // Any texture size from 2 up (the pool's grid is fixed), none below.
  EXPECT_TRUE(network->encode(test::analytic_woven_material(2, 7, 0.3F, 1.0F)));
  WovenMaterialSample broken = test::analytic_woven_material(0, 8, 0.3F, 1.0F);
  broken.orientation.resize(5);
  EXPECT_FALSE(network->encode(broken));
}

TEST(WovenNetwork, OneBlobIsPeriodicInPositionButNotInSize) {
  std::vector<float> a(24), b(24), c(24), d(24);
  one_blob_footprint(0.999F, 0.5F, 0.0F, 8, a);
  one_blob_footprint(-0.001F, 0.5F, 0.0F, 8, b);
  for (int i = 0; i < 24; ++i)
    EXPECT_NEAR(a[i], b[i], 1e-5) << i;
  EXPECT_NEAR(a[0], a[7], 0.02);  // u near 1 bumps the first bin as much as the last
  one_blob_footprint(0.5F, 0.5F, 0.0F, 8, c);
  one_blob_footprint(0.5F, 0.5F, 5.0F, 8, d);
  EXPECT_GT(c[16], 0.8F);  // size 0: the first size bin
  EXPECT_LT(c[23], 1e-6F);
  EXPECT_GT(d[23], 0.8F);
  EXPECT_LT(d[16], 1e-6F);
}

TEST(WovenNetwork, SpecularOutputsAreInvertedFromGSpace) {
  EXPECT_NEAR(woven_specular_from_g(woven_specular_to_g(0.37F)), 0.37F, 1e-6);
  EXPECT_EQ(woven_specular_from_g(-1.0F), 0.0F);  // never negative
  auto network = WovenNetwork::from_weights(seeded_weights(5));
  ASSERT_TRUE(network);
  const WovenDecoderMaterial material =
      *network->prepare(test::analytic_woven_material(1, 16, 0.5F, 1.0F));
  const WovenLookup lookup{0.2F, 0.6F, 0.8F, {0.3F, 0.1F, 0.948F}, {-0.2F, 0.4F, 0.894F}};
  const std::array<float, 4> raw = network->decode_raw(material, lookup);
  const WovenComponents components = network->decode(material, lookup);
  EXPECT_EQ(components.c_warp, std::max(0.0F, raw[0]));
  EXPECT_NEAR(components.s_weft, std::max(0.0F, (std::exp(raw[3]) - 1) / 100), 1e-7);
}

}  // namespace
}  // namespace psrig::cloth
