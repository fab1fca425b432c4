// The neural woven BSDF's decoder (issue 31), seeded random weights of the
// real layer sizes (the cost does not depend on the values):
//   BM_WovenDecoderCpu: cloth::WovenNetwork::decode, one query (the CPU twin);
//   BM_WovenEncoderCpu/T: the encoder on a T x T material (once per
//     material, or per pattern or (alpha, beta) edit);
//   BM_WovenDecoderGlsl/uniform_block:0|1/fusion:F/angular:A/blob_bins:B/features:N:
//     the GLSL pass over a 1920x1080 frame on llvmpipe, glFinish'ed (ms per
//     frame; per pixel = that / 2 073 600), the weights in a texture (0,
//     the default) or a uniform block (1), the fusion layers F wide, the
//     angular decoder's A, B one-blob bins an input (the defaults 32, 32,
//     8; 16, 16, 8 a narrower network; 32, 32, 16 and 48, 32, 16 finer
//     footprint encodings; 32, 64, 8 a wider angular decoder), N the
//     footprint's features (0, or 12: cloth/woven_footprint_features.h,
//     read from the material's table);
//   BM_WovenClearFrame: the same target cleared and finished, the floor.

#include <GLES3/gl3.h>
#include <map>
#include <memory>
#include <random>

#include <benchmark/benchmark.h>

#include "psrig/cloth/woven_network.h"
#include "psrig/preview/egl_context.h"
#include "psrig/preview/offscreen_target.h"
#include "psrig/preview/woven_decoder_pass.h"
#include "woven_standin.h"

namespace {

using namespace psrig;

const cv::Size kWovenFrame(1920, 1080);

// The default sizes, or the decoder's fusion and angular widths, the
// one-blob bins and the footprint features given (what another network
// would cost).
struct DecoderSizes {
  int fusion = 32, angular = 32, blob_bins = 8, features = 0;
  auto operator<=>(const DecoderSizes&) const = default;
};

const cloth::WovenNetwork& woven_network(DecoderSizes sizes = {}) {
  static std::map<DecoderSizes, cloth::WovenNetwork> networks;
  auto found = networks.find(sizes);
  if (found == networks.end()) {
    cloth::WovenNetworkShape shape;
    shape.fusion_width = sizes.fusion;
    shape.angular_width = sizes.angular;
    shape.blob_bins = sizes.blob_bins;
    shape.footprint_features = sizes.features;
    found = networks
                .emplace(sizes,
                         *cloth::WovenNetwork::from_weights(*cloth::random_woven_network(shape, 5)))
                .first;
  }
  return found->second;
}

void BM_WovenDecoderCpu(benchmark::State& state) {
  const cloth::WovenNetwork& network = woven_network();
  const cloth::WovenDecoderMaterial material =
      *network.prepare(test::analytic_woven_material(2, 32, 0.4F, 1.0F));
  std::mt19937 random(1);
  std::uniform_real_distribution<float> unit(0.0F, 1.0F);
  std::vector<cloth::WovenLookup> lookups(1024);
  for (auto& l : lookups) {
    l = {unit(random), unit(random), 5 * unit(random), {0.3F, 0.2F, 0.93F}, {-0.1F, 0.4F, 0.91F}};
  }
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(network.decode(material, lookups[i++ & 1023]));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_WovenDecoderCpu);

void BM_WovenEncoderCpu(benchmark::State& state) {
  const cloth::WovenNetwork& network = woven_network();
  const cloth::WovenMaterialSample material =
      test::analytic_woven_material(2, static_cast<int>(state.range(0)), 0.4F, 1.0F);
  for (auto _ : state) {
    benchmark::DoNotOptimize(network.encode(material));
  }
}
BENCHMARK(BM_WovenEncoderCpu)->Arg(32)->Arg(64)->Unit(benchmark::kMillisecond);

// One context for every benchmark here (opening EGL is slow).
preview::EglContext* woven_context() {
  static std::unique_ptr<preview::EglContext> context = [] {
    auto opened = preview::EglContext::open_surfaceless();
    return opened ? std::move(*opened) : nullptr;
  }();
  return context.get();
}

struct WovenCanvas {
  std::unique_ptr<preview::OffscreenTarget> target;
  std::unique_ptr<preview::WovenDecoderPass> pass;
};

// One per weight storage (0: a texture, 1: a uniform block) and decoder sizes.
WovenCanvas* woven_canvas(int storage, DecoderSizes sizes = {}) {
  static std::map<std::pair<int, DecoderSizes>, WovenCanvas*> opened;
  WovenCanvas*& canvas = opened[{storage, sizes}];
  if (canvas != nullptr) return canvas;
  canvas = [storage, sizes] {
    auto* made = new WovenCanvas;
    if (woven_context() == nullptr) return made;
    auto target = preview::OffscreenTarget::create(kWovenFrame, 0, preview::ColourStorage::linear);
    const cloth::WovenNetwork& network = woven_network(sizes);
    auto pass = preview::WovenDecoderPass::create(
        network, storage == 0 ? preview::WovenWeightStorage::texture
                              : preview::WovenWeightStorage::uniform_block);
    if (!target || !pass) return made;
    made->target = std::move(*target);
    made->pass = std::move(*pass);
    made->pass->set_material(*network.prepare(test::analytic_woven_material(2, 32, 0.4F, 1.0F)));
    cv::Mat footprints(kWovenFrame, CV_32FC3), incoming(kWovenFrame, CV_32FC3),
        outgoing(kWovenFrame, CV_32FC3);
    cv::randu(footprints, 0.0F, 1.0F);
    incoming.setTo(cv::Scalar(0.3F, 0.2F, 0.93F));
    outgoing.setTo(cv::Scalar(-0.1F, 0.4F, 0.91F));
    if (!made->pass->set_queries(footprints, incoming, outgoing)) {
      made->pass.reset();
      return made;
    }
    // llvmpipe compiles a shader at its first draw (seconds for this one):
    // not part of a frame.
    made->target->bind();
    made->pass->draw(preview::WovenColours{});
    glFinish();
    return made;
  }();
  return canvas;
}

void BM_WovenDecoderGlsl(benchmark::State& state) {
  WovenCanvas* canvas =
      woven_canvas(static_cast<int>(state.range(0)),
                   {static_cast<int>(state.range(1)), static_cast<int>(state.range(2)),
                    static_cast<int>(state.range(3)), static_cast<int>(state.range(4))});
  if (!canvas->pass) {
    state.SkipWithError("no EGL context or the pass did not build");
    return;
  }
  canvas->target->bind();
  const preview::WovenColours colours;
  for (auto _ : state) {
    canvas->pass->draw(colours);
    glFinish();
  }
  state.counters["ns_per_pixel"] = benchmark::Counter(
      static_cast<double>(kWovenFrame.area()),
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_WovenDecoderGlsl)
    ->ArgNames({"uniform_block", "fusion", "angular", "blob_bins", "features"})
    ->Args({0, 32, 32, 8, 0})
    ->Args({1, 32, 32, 8, 0})
    ->Args({0, 16, 16, 8, 0})
    ->Args({0, 32, 32, 16, 0})
    ->Args({0, 48, 32, 16, 0})
    ->Args({0, 32, 32, 8, 12})
    ->Args({0, 32, 32, 16, 12})
    ->Args({0, 32, 64, 8, 12})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_WovenClearFrame(benchmark::State& state) {
  WovenCanvas* canvas = woven_canvas(0);
  if (!canvas->target) {
    state.SkipWithError("no EGL context");
    return;
  }
  canvas->target->bind();
  for (auto _ : state) {
    glClearColor(0.1F, 0.2F, 0.3F, 1.0F);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glFinish();
  }
}
BENCHMARK(BM_WovenClearFrame)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
