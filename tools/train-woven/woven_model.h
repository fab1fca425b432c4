#pragma once
// The neural woven BSDF in libtorch, layer for layer the network of
// cloth/woven_network_weights.h (its comment draws it), with the loss of
// chen2024 eq. 9-11. Only the trainer includes torch: the runtime reads
// the exported weights (to_weights) without it.

#include <torch/torch.h>

#include "psrig/cloth/woven_dataset.h"
#include "psrig/cloth/woven_footprint_features.h"
#include "psrig/cloth/woven_network_weights.h"

namespace psrig::train_woven {

// leaky(x + second(leaky(first(x)))): Figure 3's block, the skip joining
// before the last activation.
struct ResidualBlockImpl : torch::nn::Module {
  explicit ResidualBlockImpl(int width);
  torch::Tensor forward(const torch::Tensor& x);
  torch::nn::Linear first{nullptr}, second{nullptr};
};
TORCH_MODULE(ResidualBlock);

struct WovenEncoderImpl : torch::nn::Module {
  explicit WovenEncoderImpl(const cloth::WovenNetworkShape& shape);
  // textures [N, 6, T, T], parameters [N, 2] (alpha, beta) -> latents [N, latent]
  torch::Tensor forward(const torch::Tensor& textures, const torch::Tensor& parameters);
  cloth::WovenNetworkShape shape;
  torch::nn::Conv2d conv0{nullptr}, conv1{nullptr}, conv2{nullptr};
  torch::nn::Linear enc_in{nullptr}, enc_out{nullptr};
  ResidualBlock enc_res{nullptr};
};
TORCH_MODULE(WovenEncoder);

struct WovenDecoderImpl : torch::nn::Module {
  explicit WovenDecoderImpl(const cloth::WovenNetworkShape& shape);
  // latents [B, latent], footprints [B, cloth::decoder_footprint_inputs],
  // angular [B, 5] -> [B, 4] (C_warp, C_weft, g(S_warp), g(S_weft))
  torch::Tensor forward(const torch::Tensor& latents, const torch::Tensor& footprints,
                        const torch::Tensor& angular);
  torch::nn::Linear fuse1{nullptr}, fuse2{nullptr}, ang_in{nullptr}, ang_mid{nullptr},
      ang_out{nullptr};
  ResidualBlock ang_res{nullptr};
};
TORCH_MODULE(WovenDecoder);

struct WovenModelImpl : torch::nn::Module {
  explicit WovenModelImpl(const cloth::WovenNetworkShape& shape);
  cloth::WovenNetworkShape shape;
  WovenEncoder encoder{nullptr};
  WovenDecoder decoder{nullptr};
};
TORCH_MODULE(WovenModel);

// A material's encoder inputs: [1, 6, T, T] (normal xyz, orientation xyz
// as channels) and [1, 2].
torch::Tensor material_textures(const cloth::WovenMaterialSample& material);
torch::Tensor material_parameters(const cloth::WovenMaterialSample& material);

// Each material's footprint features' table where `shape` takes them
// (empty tables where it does not).
std::vector<cloth::WovenFootprintFeatures> footprint_feature_tables(
    const cloth::WovenDataset& dataset, const cloth::WovenNetworkShape& shape);

// The decoder's inputs and the targets of every query, computed once:
// footprints [Q, cloth::decoder_footprint_inputs] (one-blob and features
// from `features`, footprint_feature_tables', by
// cloth::woven_footprint_inputs as the runtime computes them), directions
// [Q, 5], targets [Q, 4] with the specular ones through g.
struct QueryTensors {
  torch::Tensor footprints, angular, targets;
  torch::Tensor materials;  // [Q] int64
};
QueryTensors query_tensors(const cloth::WovenDataset& dataset,
                           const cloth::WovenNetworkShape& shape,
                           const std::vector<cloth::WovenFootprintFeatures>& features);

// Eq. 11: lambda_S (MSE of g(S_warp)) + lambda_S (MSE of g(S_weft)) +
// lambda_C (MSE of C_warp) + lambda_C (MSE of C_weft); lambda_C may be
// given (TrainingOptions::diffuse_loss_weight).
inline constexpr double specular_weight = 0.4;  // lambda_S
inline constexpr double diffuse_weight = 0.1;   // lambda_C
torch::Tensor woven_loss(const torch::Tensor& predicted, const torch::Tensor& targets,
                         double diffuse = diffuse_weight);

// The trained layers as the runtime reads them.
cloth::WovenNetworkWeights to_weights(WovenModel& model);

}  // namespace psrig::train_woven
