// The woven network's weights file, `psrig-woven-net/1` or `/2`.
// Little-endian; u32, u64, f32 as in woven_dataset.cpp, a text is a u32
// byte count and the bytes.
//
//   magic    18 bytes "psrig-woven-net/1\n" or "psrig-woven-net/2\n"
//   shape    9 x u32: conv channels (3), pool grid, encoder width, latent
//            size, blob bins, fusion width, angular width; /2 then a 10th,
//            the footprint features (woven_footprint_features.h; /1 has none)
//   seed u64, steps u64, final loss f32, command text   (what made it)
//   layers   in the order conv0 conv1 conv2 enc_in enc_res1 enc_res2
//            enc_out fuse1 fuse2 ang_in ang_res1 ang_res2 ang_mid ang_out;
//            each: name text, outputs u32, inputs u32, kernel u32 (3 for
//            a convolution, 1 for a dense layer), then the weight
//            (outputs x inputs x kernel x kernel f32, row-major, PyTorch's
//            order) and the bias (outputs f32)
//
// The file ends after the last layer. Every layer's name and sizes are
// checked against the shape, so a file from another network is refused
// naming the layer.

#include "psrig/cloth/woven_network_weights.h"

#include <cmath>
#include <fmt/format.h>
#include <random>

#include "binary_file.h"
#include "psrig/cloth/woven_footprint_features.h"

namespace psrig::cloth {
namespace {

constexpr std::string_view network_magic = "psrig-woven-net/1\n";
// A network whose decoder also takes the footprint's features.
constexpr std::string_view featured_network_magic = "psrig-woven-net/2\n";

struct LayerSlot {
  std::string_view name;
  int kernel;  // 3: convolution, 1: dense
  int inputs, outputs;
  std::vector<float>* weight;
  std::vector<float>* bias;
};

// Every layer with the sizes the shape gives it, in the file's order.
std::vector<LayerSlot> layer_slots(WovenNetworkWeights& w) {
  const WovenNetworkShape& s = w.shape;
  const auto& c = s.conv_channels;
  auto dense = [](std::string_view name, DenseLayer& layer, int inputs, int outputs) {
    return LayerSlot{name, 1, inputs, outputs, &layer.weight, &layer.bias};
  };
  auto conv = [](std::string_view name, ConvLayer& layer, int inputs, int outputs) {
    return LayerSlot{name, 3, inputs, outputs, &layer.weight, &layer.bias};
  };
  const int e = s.encoder_width, f = s.fusion_width, a = s.angular_width;
  return {
      conv("conv0", w.conv[0], 6, c[0]),
      conv("conv1", w.conv[1], c[0], c[1]),
      conv("conv2", w.conv[2], c[1], c[2]),
      dense("enc_in", w.enc_in, encoder_features(s), e),
      dense("enc_res1", w.enc_res1, e, e),
      dense("enc_res2", w.enc_res2, e, e),
      dense("enc_out", w.enc_out, e, s.latent_size),
      dense("fuse1", w.fuse1, s.latent_size + decoder_footprint_inputs(s), f),
      dense("fuse2", w.fuse2, f, f),
      dense("ang_in", w.ang_in, f + woven_angular_inputs, a),
      dense("ang_res1", w.ang_res1, a, a),
      dense("ang_res2", w.ang_res2, a, a),
      dense("ang_mid", w.ang_mid, a, a),
      dense("ang_out", w.ang_out, a, woven_outputs),
  };
}

// The same, to read (the slots' pointers are then only read through).
std::vector<LayerSlot> layer_slots(const WovenNetworkWeights& w) {
  return layer_slots(const_cast<WovenNetworkWeights&>(w));
}

template <class Layer>
void set_sizes(Layer& layer, int inputs, int outputs) {
  layer.inputs = inputs;
  layer.outputs = outputs;
}

// The dense and conv layers' own inputs/outputs fields, set from the slots.
void set_all_sizes(WovenNetworkWeights& w) {
  const WovenNetworkShape& s = w.shape;
  set_sizes(w.conv[0], 6, s.conv_channels[0]);
  set_sizes(w.conv[1], s.conv_channels[0], s.conv_channels[1]);
  set_sizes(w.conv[2], s.conv_channels[1], s.conv_channels[2]);
  set_sizes(w.enc_in, encoder_features(s), s.encoder_width);
  set_sizes(w.enc_res1, s.encoder_width, s.encoder_width);
  set_sizes(w.enc_res2, s.encoder_width, s.encoder_width);
  set_sizes(w.enc_out, s.encoder_width, s.latent_size);
  set_sizes(w.fuse1, s.latent_size + decoder_footprint_inputs(s), s.fusion_width);
  set_sizes(w.fuse2, s.fusion_width, s.fusion_width);
  set_sizes(w.ang_in, s.fusion_width + woven_angular_inputs, s.angular_width);
  set_sizes(w.ang_res1, s.angular_width, s.angular_width);
  set_sizes(w.ang_res2, s.angular_width, s.angular_width);
  set_sizes(w.ang_mid, s.angular_width, s.angular_width);
  set_sizes(w.ang_out, s.angular_width, woven_outputs);
}

std::size_t weight_count(const LayerSlot& slot) {
  return static_cast<std::size_t>(slot.outputs) * slot.inputs * slot.kernel * slot.kernel;
}

Status check_shape(const WovenNetworkShape& s, const std::filesystem::path& file) {
  auto refuse = [&](const std::string& what) {
    return std::unexpected(bad_input(file, "", "the woven network's shape: " + what));
  };
  for (int channels : s.conv_channels) {
    if (channels < 1 || channels > 1024) {
      return refuse(fmt::format("{} convolution channels, not 1 to 1024", channels));
    }
  }
  if (s.pool_grid < 1 || s.pool_grid > 16) {
    return refuse(fmt::format("pool grid {}, not 1 to 16", s.pool_grid));
  }
  if (s.blob_bins < 2 || s.blob_bins > 64) {
    return refuse(fmt::format("{} one-blob bins, not 2 to 64", s.blob_bins));
  }
  for (int width : {s.encoder_width, s.latent_size, s.fusion_width, s.angular_width}) {
    if (width < 4 || width > 1024) {
      return refuse(fmt::format("a layer {} wide, not 4 to 1024", width));
    }
  }
  if (s.footprint_features != 0 && s.footprint_features != woven_footprint_feature_count) {
    return refuse(fmt::format("{} footprint features, not 0 or {}", s.footprint_features,
                              woven_footprint_feature_count));
  }
  if (s.fusion_width % 4 != 0 || s.angular_width % 4 != 0 || (3 * s.blob_bins) % 4 != 0) {
    return refuse(
        fmt::format("fusion width {}, angular width {} and 3 x {} blob bins must be "
                    "multiples of 4 (the GLSL decoder reads vec4s)",
                    s.fusion_width, s.angular_width, s.blob_bins));
  }
  return {};
}

}  // namespace

int encoder_features(const WovenNetworkShape& shape) {
  return shape.conv_channels[2] * shape.pool_grid * shape.pool_grid + 2;
}

int decoder_blob_inputs(const WovenNetworkShape& shape) {
  return 3 * shape.blob_bins;
}

int decoder_footprint_inputs(const WovenNetworkShape& shape) {
  return decoder_blob_inputs(shape) + shape.footprint_features;
}

Status check_woven_network(const WovenNetworkWeights& weights, const std::filesystem::path& file) {
  if (auto ok = check_shape(weights.shape, file); !ok) {
    return ok;
  }
  for (const LayerSlot& slot : layer_slots(weights)) {
    if (slot.weight->size() != weight_count(slot) ||
        slot.bias->size() != static_cast<std::size_t>(slot.outputs)) {
      return std::unexpected(bad_input(
          file, "",
          fmt::format("layer {}: {} weights and {} biases, the shape wants {} and {}", slot.name,
                      slot.weight->size(), slot.bias->size(), weight_count(slot), slot.outputs)));
    }
  }
  return {};
}

Result<WovenNetworkWeights> random_woven_network(const WovenNetworkShape& shape,
                                                 std::uint64_t seed) {
  WovenNetworkWeights weights;
  weights.shape = shape;
  if (auto ok = check_shape(shape, {}); !ok) {
    return std::unexpected(ok.error());
  }
  set_all_sizes(weights);
  std::mt19937_64 random(seed);
  for (const LayerSlot& slot : layer_slots(weights)) {
    const float fan_in = static_cast<float>(slot.inputs * slot.kernel * slot.kernel);
    const float bound = std::sqrt(6.0F / fan_in);
    std::uniform_real_distribution<float> uniform(-bound, bound);
    slot.weight->resize(weight_count(slot));
    for (float& value : *slot.weight) {
      value = uniform(random);
    }
    std::uniform_real_distribution<float> small(-0.1F, 0.1F);
    slot.bias->resize(static_cast<std::size_t>(slot.outputs));
    for (float& value : *slot.bias) {
      value = small(random);
    }
  }
  weights.command = "random_woven_network";
  weights.seed = seed;
  return weights;
}

Status write_woven_network(const std::filesystem::path& file, const WovenNetworkWeights& weights) {
  if (auto ok = check_woven_network(weights, file); !ok) {
    return ok;
  }
  binary::Writer out;
  const WovenNetworkShape& s = weights.shape;
  // Without features, the first version's bytes.
  const std::string_view magic = s.footprint_features ? featured_network_magic : network_magic;
  out.bytes(magic.data(), magic.size());
  for (int value : {s.conv_channels[0], s.conv_channels[1], s.conv_channels[2], s.pool_grid,
                    s.encoder_width, s.latent_size, s.blob_bins, s.fusion_width, s.angular_width}) {
    out.u32(static_cast<std::uint32_t>(value));
  }
  if (s.footprint_features) out.u32(static_cast<std::uint32_t>(s.footprint_features));
  out.u64(weights.seed);
  out.u64(weights.steps);
  out.f32(weights.final_loss);
  out.text(weights.command);
  for (const LayerSlot& slot : layer_slots(weights)) {
    out.text(slot.name);
    out.u32(static_cast<std::uint32_t>(slot.outputs));
    out.u32(static_cast<std::uint32_t>(slot.inputs));
    out.u32(static_cast<std::uint32_t>(slot.kernel));
    out.floats(*slot.weight);
    out.floats(*slot.bias);
  }
  return binary::write_file_atomically(file, out.buffer());
}

Result<WovenNetworkWeights> read_woven_network(const std::filesystem::path& file) {
  auto bytes = binary::read_whole_file(file);
  if (!bytes) {
    return std::unexpected(bytes.error());
  }
  const bool featured =
      std::string_view(bytes->data(), bytes->size()).starts_with(featured_network_magic);
  binary::Reader in(file, *bytes);
  if (auto ok = in.expect_magic(featured ? featured_network_magic : network_magic); !ok) {
    return std::unexpected(ok.error());
  }
  WovenNetworkWeights weights;
  WovenNetworkShape& s = weights.shape;
  std::vector<int*> fields{&s.conv_channels[0], &s.conv_channels[1], &s.conv_channels[2],
                           &s.pool_grid,        &s.encoder_width,    &s.latent_size,
                           &s.blob_bins,        &s.fusion_width,     &s.angular_width};
  if (featured) fields.push_back(&s.footprint_features);
  for (int* field : fields) {
    auto value = in.u32("the network's shape");
    if (!value) {
      return std::unexpected(value.error());
    }
    *field = static_cast<int>(std::min<std::uint32_t>(*value, 1U << 20));
  }
  if (auto ok = check_shape(s, file); !ok) {
    return std::unexpected(ok.error());
  }
  set_all_sizes(weights);
  auto seed = in.u64("the seed");
  auto steps = seed ? in.u64("the step count") : std::unexpected(seed.error());
  auto loss = steps ? in.f32("the final loss") : std::unexpected(steps.error());
  auto command = loss ? in.text("the command") : std::unexpected(loss.error());
  if (!command) {
    return std::unexpected(command.error());
  }
  weights.seed = *seed;
  weights.steps = *steps;
  weights.final_loss = *loss;
  weights.command = std::move(*command);
  for (const LayerSlot& slot : layer_slots(weights)) {
    auto name = in.text("a layer's name");
    auto outputs = name ? in.u32("a layer's outputs") : std::unexpected(name.error());
    auto inputs = outputs ? in.u32("a layer's inputs") : std::unexpected(outputs.error());
    auto kernel = inputs ? in.u32("a layer's kernel") : std::unexpected(inputs.error());
    if (!kernel) {
      return std::unexpected(kernel.error());
    }
    if (*name != slot.name || *outputs != static_cast<std::uint32_t>(slot.outputs) ||
        *inputs != static_cast<std::uint32_t>(slot.inputs) ||
        *kernel != static_cast<std::uint32_t>(slot.kernel)) {
      return std::unexpected(in.fail(fmt::format(
          "layer \"{}\" {} x {} (kernel {}) where the shape wants \"{}\" {} x {} (kernel {})",
          *name, *outputs, *inputs, *kernel, slot.name, slot.outputs, slot.inputs, slot.kernel)));
    }
    auto weight = in.floats(weight_count(slot), fmt::format("layer {}'s weights", slot.name));
    auto bias = weight ? in.floats(static_cast<std::uint64_t>(slot.outputs),
                                   fmt::format("layer {}'s biases", slot.name))
                       : std::unexpected(weight.error());
    if (!bias) {
      return std::unexpected(bias.error());
    }
    *slot.weight = std::move(*weight);
    *slot.bias = std::move(*bias);
  }
  if (in.left() != 0) {
    return std::unexpected(in.fail(fmt::format("{} bytes after the last layer", in.left())));
  }
  return weights;
}

}  // namespace psrig::cloth
