// The CPU twin (cloth/woven_network.h) against libtorch's forward pass on
// the same weights: encoder and decoder agree to ~1e-5, on textures whose
// size the convolutions and the pool do not divide evenly too, with the
// footprint's features and without.

#include "woven_model.h"

#include <gtest/gtest.h>

#include "psrig/cloth/woven_network.h"
#include "woven_standin.h"

namespace psrig::train_woven {
namespace {

// |a - b| within 1e-5 of the larger magnitude (at least 1).
void expect_close(float a, float b, const std::string& what) {
  const float scale = std::max({1.0F, std::abs(a), std::abs(b)});
  EXPECT_LE(std::abs(a - b), 1e-5F * scale) << what << ": torch " << a << ", CPU " << b;
}

// (texture size, footprint features)
class TorchAgainstCpu : public testing::TestWithParam<std::tuple<int, int>> {};

TEST_P(TorchAgainstCpu, EncoderAndDecoderMatch) {
  const auto [texture_size, features] = GetParam();
  torch::manual_seed(5);
  cloth::WovenNetworkShape shape;
  shape.footprint_features = features;
  WovenModel model{shape};
  auto network = cloth::WovenNetwork::from_weights(to_weights(model));
  ASSERT_TRUE(network) << network.error().describe();

  cloth::WovenDataset dataset = test::analytic_woven_dataset(3, 40, texture_size, 9);
  torch::NoGradGuard no_grad;
  const QueryTensors queries =
      query_tensors(dataset, model->shape, footprint_feature_tables(dataset, model->shape));
  for (std::size_t m = 0; m < dataset.materials.size(); ++m) {
    const cloth::WovenMaterialSample& material = dataset.materials[m];
    const torch::Tensor latent =
        model->encoder(material_textures(material), material_parameters(material));
    auto cpu_latent = network->encode(material);
    ASSERT_TRUE(cpu_latent) << cpu_latent.error().describe();
    ASSERT_EQ(latent.numel(), static_cast<std::int64_t>(cpu_latent->size()));
    for (std::size_t i = 0; i < cpu_latent->size(); ++i) {
      expect_close(latent[0][static_cast<std::int64_t>(i)].item<float>(), (*cpu_latent)[i],
                   "latent " + std::to_string(i) + " of material " + std::to_string(m));
    }

    // The torch decoder on the torch latent, the CPU decoder on its own.
    const cloth::WovenDecoderMaterial prepared = network->prepare(*cpu_latent, material);
    for (std::size_t q = 0; q < dataset.queries.size(); ++q) {
      const cloth::WovenQuery& query = dataset.queries[q];
      if (query.material != m) continue;
      const auto row = static_cast<std::int64_t>(q);
      const torch::Tensor out = model->decoder(latent, queries.footprints.slice(0, row, row + 1),
                                               queries.angular.slice(0, row, row + 1));
      const std::array<float, 4> cpu =
          network->decode_raw(prepared, {query.u, query.v, query.size, query.wi, query.wo});
      for (int c = 0; c < 4; ++c) {
        expect_close(out[0][c].item<float>(), cpu[static_cast<std::size_t>(c)],
                     "query " + std::to_string(q) + " component " + std::to_string(c));
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(TextureSizes, TorchAgainstCpu,
                         testing::Combine(testing::Values(32, 30, 24, 7),
                                          testing::Values(0,
                                                          cloth::woven_footprint_feature_count)));

TEST(WovenLoss, WeighsSpecularAndDiffuseAsEquationEleven) {
  const torch::Tensor predicted = torch::zeros({2, 4});
  const torch::Tensor targets = torch::tensor({{1.0F, 0.0F, 0.0F, 0.0F}, {1.0F, 0.0F, 2.0F, 0.0F}});
  // diffuse: 0.1 * mean(1, 1); specular: 0.4 * mean(0, 4)
  EXPECT_NEAR(woven_loss(predicted, targets).item<double>(), 0.1 * 1.0 + 0.4 * 2.0, 1e-6);
  // --diffuse-weight 4: lambda_C alone changes
  EXPECT_NEAR(woven_loss(predicted, targets, 4.0).item<double>(), 4.0 * 1.0 + 0.4 * 2.0, 1e-6);
}

}  // namespace
}  // namespace psrig::train_woven
