#include "psrig/cloth/woven_network.h"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <tuple>

namespace psrig::cloth {
namespace {

constexpr float leaky_slope = 0.01F;        // PyTorch's default, as trained
constexpr int widest_decoder_layer = 1024;  // check_woven_network's bound

float leaky(float x) {
  return x > 0 ? x : leaky_slope * x;
}

// out = W in + b, optionally through the leaky ReLU.
void dense(const DenseLayer& layer, const float* in, float* out, bool activate) {
  for (int o = 0; o < layer.outputs; ++o) {
    const float* row = layer.weight.data() + static_cast<std::size_t>(o) * layer.inputs;
    float sum = layer.bias[o];
    for (int i = 0; i < layer.inputs; ++i) {
      sum += row[i] * in[i];
    }
    out[o] = activate ? leaky(sum) : sum;
  }
}

// x = leaky(x + W2 leaky(W1 x + b1) + b2), in place; `scratch` two layers wide.
void residual(const DenseLayer& first, const DenseLayer& second, float* x, float* scratch) {
  float* hidden = scratch;
  float* back = scratch + first.outputs;
  dense(first, x, hidden, true);
  dense(second, hidden, back, false);
  for (int i = 0; i < second.outputs; ++i) {
    x[i] = leaky(x[i] + back[i]);
  }
}

// out = W in + b for an input-major layer (`bias` replaces the layer's own
// when given), optionally through the leaky ReLU.
void dense_input_major(const WovenDecoderLayer& layer, const float* in, float* out, bool activate,
                       const float* bias = nullptr) {
  const int outputs = layer.outputs;
  std::copy_n(bias != nullptr ? bias : layer.bias.data(), outputs, out);
  for (int i = 0; i < layer.inputs; ++i) {
    const float* column = layer.weight.data() + static_cast<std::size_t>(i) * outputs;
    const float x = in[i];
    for (int o = 0; o < outputs; ++o) {
      out[o] += column[o] * x;
    }
  }
  if (activate) {
    for (int o = 0; o < outputs; ++o)
      out[o] = leaky(out[o]);
  }
}

// The columns [first, first + count) of `layer`, input-major.
WovenDecoderLayer input_major(const DenseLayer& layer, int first = 0, int count = -1) {
  if (count < 0) count = layer.inputs - first;
  WovenDecoderLayer out{count, layer.outputs,
                        std::vector<float>(static_cast<std::size_t>(count) * layer.outputs),
                        layer.bias};
  for (int o = 0; o < layer.outputs; ++o) {
    for (int i = 0; i < count; ++i) {
      out.weight[static_cast<std::size_t>(i) * layer.outputs + o] =
          layer.weight[static_cast<std::size_t>(o) * layer.inputs + first + i];
    }
  }
  return out;
}

// A channels x size x size map, row-major.
struct FeatureMap {
  int channels = 0, size = 0;
  std::vector<float> values;
  [[nodiscard]] float at(int c, int y, int x) const {
    return values[(static_cast<std::size_t>(c) * size + y) * size + x];
  }
};

// 3x3, stride 2, circular padding of 1 (PyTorch's padding_mode "circular"),
// then the leaky ReLU.
FeatureMap convolve(const ConvLayer& layer, const FeatureMap& in) {
  FeatureMap out{layer.outputs, (in.size - 1) / 2 + 1, {}};
  out.values.resize(static_cast<std::size_t>(out.channels) * out.size * out.size);
  auto wrap = [n = in.size](int i) { return (i % n + n) % n; };
  for (int o = 0; o < layer.outputs; ++o) {
    for (int y = 0; y < out.size; ++y) {
      for (int x = 0; x < out.size; ++x) {
        float sum = layer.bias[o];
        for (int c = 0; c < layer.inputs; ++c) {
          const float* kernel =
              layer.weight.data() + (static_cast<std::size_t>(o) * layer.inputs + c) * 9;
          for (int ky = 0; ky < 3; ++ky) {
            const int iy = wrap(2 * y - 1 + ky);
            for (int kx = 0; kx < 3; ++kx) {
              sum += kernel[ky * 3 + kx] * in.at(c, iy, wrap(2 * x - 1 + kx));
            }
          }
        }
        out.values[(static_cast<std::size_t>(o) * out.size + y) * out.size + x] = leaky(sum);
      }
    }
  }
  return out;
}

// PyTorch's adaptive_avg_pool2d: cell i covers [floor(i n / g), ceil((i + 1) n / g)).
std::vector<float> adaptive_average(const FeatureMap& in, int grid) {
  std::vector<float> out;
  out.reserve(static_cast<std::size_t>(in.channels) * grid * grid);
  auto start = [&](int i) { return (i * in.size) / grid; };
  auto end = [&](int i) { return ((i + 1) * in.size + grid - 1) / grid; };
  for (int c = 0; c < in.channels; ++c) {
    for (int gy = 0; gy < grid; ++gy) {
      for (int gx = 0; gx < grid; ++gx) {
        float sum = 0;
        for (int y = start(gy); y < end(gy); ++y) {
          for (int x = start(gx); x < end(gx); ++x) {
            sum += in.at(c, y, x);
          }
        }
        out.push_back(sum / static_cast<float>((end(gy) - start(gy)) * (end(gx) - start(gx))));
      }
    }
  }
  return out;
}

}  // namespace

float woven_specular_to_g(float specular) {
  return std::log(woven_specular_k * specular + 1.0F);
}

float woven_specular_from_g(float g) {
  return std::max(0.0F, (std::exp(g) - 1.0F) / woven_specular_k);
}

void one_blob_footprint(float u, float v, float size, int bins, std::span<float> out) {
  const float width = 1.0F / static_cast<float>(bins);
  const float scale = -0.5F / (width * width);
  const float periodic[2] = {u - std::floor(u), v - std::floor(v)};
  const float span_size = std::clamp(size / woven_largest_footprint, 0.0F, 1.0F);
  for (int k = 0; k < bins; ++k) {
    const float centre = (static_cast<float>(k) + 0.5F) * width;
    for (int axis = 0; axis < 2; ++axis) {
      float d = periodic[axis] - centre;
      d -= std::round(d);
      out[axis * bins + k] = std::exp(scale * d * d);
    }
    const float d = span_size - centre;
    out[2 * bins + k] = std::exp(scale * d * d);
  }
}

WovenNetwork::WovenNetwork(WovenNetworkWeights weights) : weights_(std::move(weights)) {
  const WovenNetworkWeights& w = weights_;
  decoder_ = {input_major(w.fuse1, w.shape.latent_size),
              input_major(w.fuse2),
              input_major(w.ang_in),
              input_major(w.ang_res1),
              input_major(w.ang_res2),
              input_major(w.ang_mid),
              input_major(w.ang_out)};
}

Result<WovenNetwork> WovenNetwork::load(const std::filesystem::path& file) {
  auto weights = read_woven_network(file);
  if (!weights) {
    return std::unexpected(weights.error());
  }
  return WovenNetwork(std::move(*weights));
}

Result<WovenNetwork> WovenNetwork::from_weights(WovenNetworkWeights weights) {
  if (auto ok = check_woven_network(weights); !ok) {
    return std::unexpected(ok.error());
  }
  return WovenNetwork(std::move(weights));
}

Result<std::vector<float>> WovenNetwork::encode(const WovenMaterialSample& material) const {
  const int size = material.texture_size;
  const auto texels = static_cast<std::size_t>(size) * size;
  if (size < 2 || material.normal.size() != texels * 3 ||
      material.orientation.size() != texels * 3) {
    return std::unexpected(bad_input(
        {}, "",
        fmt::format("material \"{}\": texture size {} with {} normal and {} orientation floats",
                    material.pattern, size, material.normal.size(), material.orientation.size())));
  }
  FeatureMap map{6, size, std::vector<float>(texels * 6)};
  for (std::size_t t = 0; t < texels; ++t) {
    for (int c = 0; c < 3; ++c) {
      map.values[c * texels + t] = material.normal[t * 3 + c];
      map.values[(c + 3) * texels + t] = material.orientation[t * 3 + c];
    }
  }
  for (const ConvLayer& layer : weights_.conv) {
    map = convolve(layer, map);
  }
  std::vector<float> features = adaptive_average(map, shape().pool_grid);
  features.push_back(material.roughness);
  features.push_back(material.height_scale);

  const int width = shape().encoder_width;
  std::vector<float> hidden(width), scratch(2 * static_cast<std::size_t>(width));
  dense(weights_.enc_in, features.data(), hidden.data(), true);
  residual(weights_.enc_res1, weights_.enc_res2, hidden.data(), scratch.data());
  std::vector<float> latent(shape().latent_size);
  dense(weights_.enc_out, hidden.data(), latent.data(), false);
  return latent;
}

void woven_footprint_inputs(const WovenNetworkShape& shape, const WovenFootprintFeatures& features,
                            float u, float v, float size, std::span<float> out) {
  const int blobs = decoder_blob_inputs(shape);
  one_blob_footprint(u, v, size, shape.blob_bins, out.first(static_cast<std::size_t>(blobs)));
  if (shape.footprint_features == 0) return;
  const auto rest = out.subspan(static_cast<std::size_t>(blobs));
  if (features.empty()) {
    std::fill(rest.begin(), rest.end(), 0.0F);  // a material prepared without its textures
  } else {
    features.mean(u, v, size, rest);
  }
}

Result<WovenDecoderMaterial> WovenNetwork::prepare(const WovenMaterialSample& material) const {
  auto latent = encode(material);
  if (!latent) return std::unexpected(latent.error());
  return prepare(std::move(*latent), material);
}

WovenDecoderMaterial WovenNetwork::prepare(std::vector<float> latent,
                                           const WovenMaterialSample& sample) const {
  const DenseLayer& fuse = weights_.fuse1;
  WovenDecoderMaterial material{std::move(latent), std::vector<float>(fuse.outputs), {}};
  if (shape().footprint_features > 0) material.features = WovenFootprintFeatures(sample);
  for (int o = 0; o < fuse.outputs; ++o) {
    const float* row = fuse.weight.data() + static_cast<std::size_t>(o) * fuse.inputs;
    float sum = fuse.bias[o];
    for (int l = 0; l < shape().latent_size; ++l) {
      sum += row[l] * material.latent[l];
    }
    material.fusion_bias[o] = sum;
  }
  return material;
}

std::array<float, 4> WovenNetwork::decode_raw(const WovenDecoderMaterial& material,
                                              const WovenLookup& lookup) const {
  const WovenNetworkShape& s = shape();
  // Left uninitialised: each layer writes all it reads next.
  std::array<float, widest_decoder_layer + woven_angular_inputs> joined;
  std::array<float, widest_decoder_layer> first, second, third;
  float footprint[3 * 64 + woven_footprint_feature_count];
  woven_footprint_inputs(
      s, material.features, lookup.u, lookup.v, lookup.size,
      std::span(footprint, static_cast<std::size_t>(decoder_footprint_inputs(s))));
  const auto& [fuse1, fuse2, ang_in, ang_res1, ang_res2, ang_mid, ang_out] = std::tie(
      decoder_[0], decoder_[1], decoder_[2], decoder_[3], decoder_[4], decoder_[5], decoder_[6]);

  // fuse1: the latent's share is the material's fusion bias.
  dense_input_major(fuse1, footprint, first.data(), true, material.fusion_bias.data());
  dense_input_major(fuse2, first.data(), joined.data(), true);
  float* directions = joined.data() + s.fusion_width;
  directions[0] = lookup.wi[0];
  directions[1] = lookup.wi[1];
  directions[2] = lookup.wi[2];
  directions[3] = lookup.wo[0];
  directions[4] = lookup.wo[1];
  dense_input_major(ang_in, joined.data(), first.data(), true);
  // The residual block: leaky(x + W2 leaky(W1 x + b1) + b2).
  dense_input_major(ang_res1, first.data(), second.data(), true);
  dense_input_major(ang_res2, second.data(), third.data(), false);
  for (int i = 0; i < s.angular_width; ++i)
    first[i] = leaky(first[i] + third[i]);
  dense_input_major(ang_mid, first.data(), second.data(), true);
  std::array<float, 4> out;
  dense_input_major(ang_out, second.data(), out.data(), false);
  return out;
}

WovenComponents WovenNetwork::decode(const WovenDecoderMaterial& material,
                                     const WovenLookup& lookup) const {
  const std::array<float, 4> raw = decode_raw(material, lookup);
  return {std::max(0.0F, raw[0]), std::max(0.0F, raw[1]), woven_specular_from_g(raw[2]),
          woven_specular_from_g(raw[3])};
}

}  // namespace psrig::cloth
