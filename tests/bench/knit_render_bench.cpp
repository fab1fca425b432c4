// The yarn renderer's frame (issue 18's goal: 10 K stitches at 1920x1080,
// 4x MSAA, on llvmpipe, at least 3x faster than before it): stockinette
// relaxed once, stretched as the knit --bench stretches it, drawn headless
// into a 4x multisampled sRGB target, glFinish'ed as before a page flip.
//   BM_KnitFrame/<stitches>: the whole look (slice, environment, shadows);
//   BM_KnitFramePlain/<stitches>: the same yarns with no fibre detail and
//     no shadows, the cheapest look (the frame's cost that is geometry);
//   BM_KnitUpload/<stitches>: the renderer's update() alone (packing the
//     points and their upload);
//   BM_FrameClear: an empty frame of the same target, cleared and finished
//     (the floor of any frame at that size): the same run's baseline.
// Report BM_KnitFrame/10000 as frames per second and as a ratio to
// BM_FrameClear; the ratio to the renderer before issue 18 comes from
// tests/bench/knit_vs_baseline (two builds in turn).

#include <GLES3/gl3.h>

#include <cmath>
#include <filesystem>
#include <memory>

#include <benchmark/benchmark.h>

#include "psrig/cloth/knit_fabric.h"
#include "psrig/preview/egl_context.h"
#include "psrig/preview/offscreen_target.h"
#include "psrig/preview/yarn_renderer.h"

namespace {

using namespace psrig;

const cv::Size kFrame(1920, 1080);

// One context and target for every benchmark here (opening EGL is slow).
struct Canvas {
  std::unique_ptr<preview::EglContext> context;
  std::unique_ptr<preview::OffscreenTarget> target;
};

Canvas* canvas() {
  static Canvas* opened = [] {
    auto* made = new Canvas;
    auto context = preview::EglContext::open_surfaceless();
    if (!context) return made;
    made->context = std::move(*context);
    auto target = preview::OffscreenTarget::create(kFrame, 4, preview::ColourStorage::srgb);
    if (target) made->target = std::move(*target);
    return made;
  }();
  return opened->target ? opened : nullptr;
}

cloth::YarnSet stockinette(int stitches) {
  cloth::YarnSet yarns;
  const int side = static_cast<int>(std::lround(std::sqrt(static_cast<double>(stitches))));
  auto chart = cloth::load_stitch_chart(std::filesystem::path(PSRIG_SOURCE_DIR) /
                                        "config/patterns/stockinette.chart");
  if (!chart) return yarns;
  auto fabric = cloth::KnitFabric::build(*chart, side, side, {});
  if (fabric) fabric->update(fabric->mesh({1.15f, 0.1f}), yarns);
  return yarns;
}

// The stockinette of state.range(0) stitches and a renderer that has it;
// null (the state told why) without a context.
std::unique_ptr<preview::YarnRenderer> loaded_renderer(benchmark::State& state,
                                                       cloth::YarnSet& yarns) {
  if (canvas() == nullptr) {
    state.SkipWithError("no headless GLES context");
    return nullptr;
  }
  yarns = stockinette(static_cast<int>(state.range(0)));
  auto renderer = preview::YarnRenderer::create();
  if (!renderer) {
    state.SkipWithError(renderer.error().describe().c_str());
    return nullptr;
  }
  (*renderer)->update(yarns);
  return std::move(*renderer);
}

void frame(benchmark::State& state, bool full_look) {
  cloth::YarnSet yarns;
  const auto renderer = loaded_renderer(state, yarns);
  if (!renderer) return;
  preview::KnitView view;
  view.shadows = full_look;
  view.fibre_detail = full_look;
  for (auto _ : state) {
    canvas()->target->bind();
    renderer->render(view, kFrame);
    glFinish();
  }
  state.counters["fps"] = benchmark::Counter(static_cast<double>(state.iterations()),
                                             benchmark::Counter::kIsRate);
  state.counters["yarn_px"] = renderer->last_yarn_width_px();
  state.counters["vertices"] = renderer->last_strip_vertices();
}

void BM_KnitFrame(benchmark::State& state) {
  frame(state, true);
}
void BM_KnitFramePlain(benchmark::State& state) {
  frame(state, false);
}

void BM_KnitUpload(benchmark::State& state) {
  cloth::YarnSet yarns;
  const auto renderer = loaded_renderer(state, yarns);
  if (!renderer) return;
  for (auto _ : state) {
    renderer->update(yarns);
    glFinish();
  }
  state.counters["points"] = static_cast<double>(yarns.point_count());
}

void BM_FrameClear(benchmark::State& state) {
  Canvas* drawn = canvas();
  if (drawn == nullptr) {
    state.SkipWithError("no headless GLES context");
    return;
  }
  for (auto _ : state) {
    drawn->target->bind();
    glClearColor(0.02f, 0.02f, 0.025f, 1);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glFinish();
  }
}

BENCHMARK(BM_FrameClear)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_KnitFrame)->Arg(1000)->Arg(10000)->Arg(50000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_KnitFramePlain)->Arg(10000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_KnitUpload)->Arg(10000)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
