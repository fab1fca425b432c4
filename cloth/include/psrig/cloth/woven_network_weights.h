#pragma once
// The neural woven BSDF's weights (chen2024 4.2, sized for a CPU): the
// file `psrig-woven-net/1` (or /2, with footprint features) the trainer
// (tools/train-woven) writes and the runtime (woven_network.h, the
// preview's GLSL decoder) reads, without libtorch. Layout in
// src/woven_network_weights.cpp.
//
// The network, its layers named as in the file:
//   encoder  textures (6 x T x T: normal xyz, orientation xyz)
//              conv0..conv2: 3x3, stride 2, circular padding (a repeat
//              tiles), leaky ReLU -> adaptive average pool to P x P
//              -> flatten, append (alpha, beta)
//              enc_in (leaky) -> residual block enc_res1, enc_res2 -> enc_out
//            = the material latent z (no activation)
//   decoder  [z, one_blob(u, v, size), features(u, v, size)] -> fuse1, fuse2
//              (leaky): the spatial feature (features: woven_footprint_features.h,
//              none in a /1 file)
//            [spatial, wi xyz, wo xy] -> ang_in (leaky) -> residual block
//              ang_res1, ang_res2 -> ang_mid (leaky) -> ang_out
//            = C_warp, C_weft, g(S_warp), g(S_weft), g(x) = ln(100 x + 1)
// A residual block is leaky(x + W2 leaky(W1 x + b1) + b2) (Figure 3:
// the skip joins before the last leaky ReLU). Leaky ReLU slope 0.01.

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "psrig/base/error.h"

namespace psrig::cloth {

struct WovenNetworkShape {
  std::array<int, 3> conv_channels{16, 32, 32};
  int pool_grid = 4;        // P: the encoder keeps a P x P map of where things are
  int encoder_width = 128;  // the paper's 128
  int latent_size = 64;     // the paper's 64
  int blob_bins = 8;        // one-blob bins per footprint input: 3 inputs -> 24 (the paper's)
  int fusion_width = 32;    // the spatial fusion's two layers
  int angular_width = 32;   // the angular decoder's layers
  // The footprint's features beside its one-blob: 0 (the paper's decoder)
  // or woven_footprint_feature_count.
  int footprint_features = 0;
  // The GLSL decoder reads vec4s: both widths are multiples of 4.
  [[nodiscard]] bool operator==(const WovenNetworkShape&) const = default;
};

// A fully connected layer: weight is outputs x inputs, row-major.
struct DenseLayer {
  int inputs = 0, outputs = 0;
  std::vector<float> weight, bias;
};

// A 3x3 convolution: weight is outputs x inputs x 3 x 3, row-major.
struct ConvLayer {
  int inputs = 0, outputs = 0;
  std::vector<float> weight, bias;
};

struct WovenNetworkWeights {
  WovenNetworkShape shape;
  std::array<ConvLayer, 3> conv;
  DenseLayer enc_in, enc_res1, enc_res2, enc_out;
  DenseLayer fuse1, fuse2, ang_in, ang_res1, ang_res2, ang_mid, ang_out;
  // For the record: what made them.
  std::string command;
  std::uint64_t seed = 0;
  std::uint64_t steps = 0;
  float final_loss = 0;
};

// The number of inputs each layer takes for `shape` (the file is checked
// against these).
[[nodiscard]] int encoder_features(const WovenNetworkShape& shape);     // C3 * P * P + 2
[[nodiscard]] int decoder_blob_inputs(const WovenNetworkShape& shape);  // 3 * bins
// The blobs and the features: fuse1 takes the latent and these.
[[nodiscard]] int decoder_footprint_inputs(const WovenNetworkShape& shape);
inline constexpr int woven_angular_inputs = 5;                          // wi xyz, wo xy
inline constexpr int woven_outputs = 4;

// Layers sized for `shape`, filled with seeded uniform values at He's
// scale: a network of the real sizes for tests before any is trained.
[[nodiscard]] Result<WovenNetworkWeights> random_woven_network(const WovenNetworkShape& shape,
                                                               std::uint64_t seed);

// Every layer's size against the shape, and the shape itself (widths > 0,
// multiples of 4 where the GLSL decoder needs them).
[[nodiscard]] Status check_woven_network(const WovenNetworkWeights& weights,
                                         const std::filesystem::path& file = {});

// Written whole or not at all; read back with every size checked.
[[nodiscard]] Status write_woven_network(const std::filesystem::path& file,
                                         const WovenNetworkWeights& weights);
[[nodiscard]] Result<WovenNetworkWeights> read_woven_network(const std::filesystem::path& file);

}  // namespace psrig::cloth
