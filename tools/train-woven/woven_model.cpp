#include "woven_model.h"

#include "psrig/cloth/woven_network.h"

namespace psrig::train_woven {
namespace {

namespace nn = torch::nn;

torch::Tensor leaky(const torch::Tensor& x) {
  return torch::leaky_relu(x, 0.01);
}

nn::Conv2d stride_two_conv(int inputs, int outputs) {
  // Circular padding: a weave's repeat tiles, so its texture wraps.
  return nn::Conv2d(
      nn::Conv2dOptions(inputs, outputs, 3).stride(2).padding(1).padding_mode(torch::kCircular));
}

std::vector<float> flat(const torch::Tensor& tensor) {
  const torch::Tensor contiguous = tensor.detach().to(torch::kFloat32).contiguous();
  const float* data = contiguous.data_ptr<float>();
  return {data, data + contiguous.numel()};
}

cloth::DenseLayer dense_layer(const nn::Linear& linear) {
  return {static_cast<int>(linear->weight.size(1)), static_cast<int>(linear->weight.size(0)),
          flat(linear->weight), flat(linear->bias)};
}

cloth::ConvLayer conv_layer(const nn::Conv2d& conv) {
  return {static_cast<int>(conv->weight.size(1)), static_cast<int>(conv->weight.size(0)),
          flat(conv->weight), flat(conv->bias)};
}

}  // namespace

ResidualBlockImpl::ResidualBlockImpl(int width)
    : first(register_module("first", nn::Linear(width, width))),
      second(register_module("second", nn::Linear(width, width))) {}

torch::Tensor ResidualBlockImpl::forward(const torch::Tensor& x) {
  return leaky(x + second(leaky(first(x))));
}

WovenEncoderImpl::WovenEncoderImpl(const cloth::WovenNetworkShape& s) : shape(s) {
  const auto& c = s.conv_channels;
  conv0 = register_module("conv0", stride_two_conv(6, c[0]));
  conv1 = register_module("conv1", stride_two_conv(c[0], c[1]));
  conv2 = register_module("conv2", stride_two_conv(c[1], c[2]));
  enc_in = register_module("enc_in", nn::Linear(cloth::encoder_features(s), s.encoder_width));
  enc_res = register_module("enc_res", ResidualBlock(s.encoder_width));
  enc_out = register_module("enc_out", nn::Linear(s.encoder_width, s.latent_size));
}

torch::Tensor WovenEncoderImpl::forward(const torch::Tensor& textures,
                                        const torch::Tensor& parameters) {
  torch::Tensor x = leaky(conv2(leaky(conv1(leaky(conv0(textures))))));
  x = torch::adaptive_avg_pool2d(x, {shape.pool_grid, shape.pool_grid}).flatten(1);
  x = leaky(enc_in(torch::cat({x, parameters}, 1)));
  return enc_out(enc_res(x));
}

WovenDecoderImpl::WovenDecoderImpl(const cloth::WovenNetworkShape& s) {
  const int f = s.fusion_width, a = s.angular_width;
  fuse1 =
      register_module("fuse1", nn::Linear(s.latent_size + cloth::decoder_footprint_inputs(s), f));
  fuse2 = register_module("fuse2", nn::Linear(f, f));
  ang_in = register_module("ang_in", nn::Linear(f + cloth::woven_angular_inputs, a));
  ang_res = register_module("ang_res", ResidualBlock(a));
  ang_mid = register_module("ang_mid", nn::Linear(a, a));
  ang_out = register_module("ang_out", nn::Linear(a, cloth::woven_outputs));
}

torch::Tensor WovenDecoderImpl::forward(const torch::Tensor& latents,
                                        const torch::Tensor& footprints,
                                        const torch::Tensor& angular) {
  const torch::Tensor spatial = leaky(fuse2(leaky(fuse1(torch::cat({latents, footprints}, 1)))));
  torch::Tensor x = leaky(ang_in(torch::cat({spatial, angular}, 1)));
  return ang_out(leaky(ang_mid(ang_res(x))));
}

WovenModelImpl::WovenModelImpl(const cloth::WovenNetworkShape& s)
    : shape(s),
      encoder(register_module("encoder", WovenEncoder(s))),
      decoder(register_module("decoder", WovenDecoder(s))) {}

torch::Tensor material_textures(const cloth::WovenMaterialSample& material) {
  const int t = material.texture_size;
  // [T, T, 3] texels -> [3, T, T] channels, normal then orientation.
  auto channels = [t](const std::vector<float>& texels) {
    return torch::from_blob(const_cast<float*>(texels.data()), {t, t, 3}, torch::kFloat32)
        .permute({2, 0, 1});
  };
  return torch::cat({channels(material.normal), channels(material.orientation)}, 0)
      .unsqueeze(0)
      .contiguous();
}

torch::Tensor material_parameters(const cloth::WovenMaterialSample& material) {
  return torch::tensor({material.roughness, material.height_scale}, torch::kFloat32).unsqueeze(0);
}

std::vector<cloth::WovenFootprintFeatures> footprint_feature_tables(
    const cloth::WovenDataset& dataset, const cloth::WovenNetworkShape& shape) {
  std::vector<cloth::WovenFootprintFeatures> tables(dataset.materials.size());
  if (shape.footprint_features > 0) {
    for (std::size_t m = 0; m < tables.size(); ++m)
      tables[m] = cloth::WovenFootprintFeatures(dataset.materials[m]);
  }
  return tables;
}

QueryTensors query_tensors(const cloth::WovenDataset& dataset,
                           const cloth::WovenNetworkShape& shape,
                           const std::vector<cloth::WovenFootprintFeatures>& features) {
  const auto count = static_cast<std::int64_t>(dataset.queries.size());
  const int inputs = cloth::decoder_footprint_inputs(shape);
  QueryTensors out{
      torch::empty({count, inputs}), torch::empty({count, cloth::woven_angular_inputs}),
      torch::empty({count, cloth::woven_outputs}), torch::empty({count}, torch::kInt64)};
  float* footprints = out.footprints.data_ptr<float>();
  float* angular = out.angular.data_ptr<float>();
  float* targets = out.targets.data_ptr<float>();
  std::int64_t* materials = out.materials.data_ptr<std::int64_t>();
  for (std::int64_t q = 0; q < count; ++q) {
    const cloth::WovenQuery& query = dataset.queries[static_cast<std::size_t>(q)];
    cloth::woven_footprint_inputs(
        shape, features[query.material], query.u, query.v, query.size,
        std::span(footprints + q * inputs, static_cast<std::size_t>(inputs)));
    const float directions[5] = {query.wi[0], query.wi[1], query.wi[2], query.wo[0], query.wo[1]};
    std::copy_n(directions, 5, angular + q * 5);
    targets[q * 4 + 0] = query.c_warp;
    targets[q * 4 + 1] = query.c_weft;
    targets[q * 4 + 2] = cloth::woven_specular_to_g(query.s_warp);
    targets[q * 4 + 3] = cloth::woven_specular_to_g(query.s_weft);
    materials[q] = query.material;
  }
  return out;
}

torch::Tensor woven_loss(const torch::Tensor& predicted, const torch::Tensor& targets,
                         double diffuse) {
  const torch::Tensor per_component = (predicted - targets).square().mean(0);  // [4]
  return diffuse * (per_component[0] + per_component[1]) +
         specular_weight * (per_component[2] + per_component[3]);
}

cloth::WovenNetworkWeights to_weights(WovenModel& model) {
  cloth::WovenNetworkWeights weights;
  weights.shape = model->shape;
  const WovenEncoder& e = model->encoder;
  const WovenDecoder& d = model->decoder;
  weights.conv = {conv_layer(e->conv0), conv_layer(e->conv1), conv_layer(e->conv2)};
  weights.enc_in = dense_layer(e->enc_in);
  weights.enc_res1 = dense_layer(e->enc_res->first);
  weights.enc_res2 = dense_layer(e->enc_res->second);
  weights.enc_out = dense_layer(e->enc_out);
  weights.fuse1 = dense_layer(d->fuse1);
  weights.fuse2 = dense_layer(d->fuse2);
  weights.ang_in = dense_layer(d->ang_in);
  weights.ang_res1 = dense_layer(d->ang_res->first);
  weights.ang_res2 = dense_layer(d->ang_res->second);
  weights.ang_mid = dense_layer(d->ang_mid);
  weights.ang_out = dense_layer(d->ang_out);
  return weights;
}

}  // namespace psrig::train_woven
