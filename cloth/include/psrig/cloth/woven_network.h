#pragma once
// The neural woven BSDF on the CPU, without libtorch (chen2024 4.2-4.3):
// the encoder turns a material (its weave's normal and orientation
// textures, roughness alpha and height scaling beta) into a latent once;
// the decoder answers each query (footprint centre and size, wi, wo) with
// the four components of eq. 7, f = kd_warp C_warp + kd_weft C_weft +
// ks_warp S_warp + ks_weft S_weft. Colour edits (k_d, k_s) touch neither;
// pattern and (alpha, beta) edits re-run only the encoder. The layers are
// those of woven_network_weights.h; the trainer's libtorch forward pass and
// the preview's GLSL decoder are tested against this one.

#include <array>
#include <filesystem>
#include <span>
#include <vector>

#include "psrig/base/error.h"
#include "psrig/cloth/woven_components.h"
#include "psrig/cloth/woven_dataset.h"
#include "psrig/cloth/woven_footprint_features.h"
#include "psrig/cloth/woven_network_weights.h"

namespace psrig::cloth {

// The footprint sizes the one-blob encoding spans, in repeats (5.1: up to
// five pattern lengths); larger ones encode as 5.
inline constexpr float woven_largest_footprint = 5.0F;
// g(x) = ln(k x + 1) (eq. 9, k = 100 for reflection): the network's
// specular outputs are g(S).
inline constexpr float woven_specular_k = 100.0F;
[[nodiscard]] float woven_specular_to_g(float specular);
[[nodiscard]] float woven_specular_from_g(float g);  // clamped at 0

// One-blob encoding (Mueller et al. 2021) of a footprint into 3 * bins
// values: Gaussian bumps of width 1/bins around each bin's centre; u and v
// periodic (a footprint at u = 0.99 lies next to one at 0.01), the size
// over [0, woven_largest_footprint]. The trainer feeds the same values.
void one_blob_footprint(float u, float v, float size, int bins, std::span<float> out);

// The decoder's footprint inputs for a query into `out`
// (decoder_footprint_inputs values): the one-blob, then the features where
// `shape` takes them (from `features`). The trainer feeds the same values.
void woven_footprint_inputs(const WovenNetworkShape& shape, const WovenFootprintFeatures& features,
                            float u, float v, float size, std::span<float> out);

// One decoder query: footprint centre (repeats), width (repeats) and the
// two directions in the cloth's frame (as WovenQuery).
struct WovenLookup {
  float u = 0, v = 0, size = 0;
  std::array<float, 3> wi{}, wo{};
};

// A material as the decoder takes it: its latent, and the latent's share
// of the first fusion layer with that layer's bias, worked out once per
// material so that a query pays only for the footprint's share; and, for a
// network that takes them, the table its footprints' features come from.
struct WovenDecoderMaterial {
  std::vector<float> latent;
  std::vector<float> fusion_bias;  // fusion_width values
  WovenFootprintFeatures features;  // empty for a network without them
};

// A decoder layer stored input-major (weight[i * outputs + o]), so that a
// query's inner loop runs over the outputs and vectorises; each output
// still sums its inputs in order, so the results are those of the
// output-major layout bit for bit.
struct WovenDecoderLayer {
  int inputs = 0, outputs = 0;
  std::vector<float> weight, bias;
};

class WovenNetwork {
 public:
  [[nodiscard]] static Result<WovenNetwork> load(const std::filesystem::path& file);
  [[nodiscard]] static Result<WovenNetwork> from_weights(WovenNetworkWeights weights);

  [[nodiscard]] const WovenNetworkWeights& weights() const { return weights_; }
  [[nodiscard]] const WovenNetworkShape& shape() const { return weights_.shape; }

  // The material latent (latent_size values). Textures of any size from 2
  // texels up (the encoder pools to a fixed grid).
  [[nodiscard]] Result<std::vector<float>> encode(const WovenMaterialSample& material) const;
  // `material`'s latent (encode's) made ready for decoding.
  [[nodiscard]] WovenDecoderMaterial prepare(std::vector<float> latent,
                                             const WovenMaterialSample& material) const;
  // encode and prepare at once.
  [[nodiscard]] Result<WovenDecoderMaterial> prepare(const WovenMaterialSample& material) const;

  // The network's outputs as trained: C_warp, C_weft, g(S_warp), g(S_weft).
  [[nodiscard]] std::array<float, 4> decode_raw(const WovenDecoderMaterial& material,
                                                const WovenLookup& lookup) const;
  // The four components, g inverted and all clamped at 0.
  [[nodiscard]] WovenComponents decode(const WovenDecoderMaterial& material,
                                       const WovenLookup& lookup) const;

 private:
  explicit WovenNetwork(WovenNetworkWeights weights);
  WovenNetworkWeights weights_;
  // fuse1's footprint columns, fuse2, ang_in, ang_res1, ang_res2, ang_mid, ang_out.
  std::vector<WovenDecoderLayer> decoder_;
};

}  // namespace psrig::cloth
