// Chart inference's cost on charts knitted head-on (tests/support/knitted_maps.h):
//   BM_ChartInference/<chart>: infer_knit_chart on 400x320 maps at 0.03 mm
//     (seed 0, 1x1 rib 1; basketweave 2 at 560x400, 0.04 mm, its 8x8
//     repeat found stitch by stitch);
//   BM_ChartInferenceMeasure/<chart>: the fabric measurement it starts
//     from, on the same maps, in the same run.
// Most of the time is the cloth model knitting candidate charts (relaxing
// their repeats), not the maps' size.

#include <benchmark/benchmark.h>

#include "knitted_maps.h"
#include "psrig/analysis/chart_inference.h"
#include "test_support.h"

namespace {

using namespace psrig;

struct Input {
  test::KnittedMaps maps;
  analysis::FabricMeasurement fabric;
};

Input input(int which) {
  const char* names[] = {"seed.chart", "rib-1x1.chart", "basketweave.chart"};
  auto chart = cloth::load_stitch_chart(test::shipped_pattern(names[which]));
  Input in;
  in.maps = which == 2 ? test::knit_maps(*chart, {560, 400}, 0.04)
                       : test::knit_maps(*chart, {400, 320}, 0.03);
  analysis::MeasureOptions options;
  options.pixel_size_mm = in.maps.pixel_size_mm;
  options.hints.construction = analysis::Construction::knit;
  in.fabric = *analysis::measure_fabric(in.maps.height, in.maps.albedo, options);
  return in;
}

void BM_ChartInference(benchmark::State& state) {
  const Input in = input(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    auto knit = analysis::infer_knit_chart(in.maps.height, in.maps.albedo, in.fabric);
    if (!knit) {
      state.SkipWithError(knit.error().describe().c_str());
      return;
    }
    benchmark::DoNotOptimize(knit->stitches.data());
  }
}
BENCHMARK(BM_ChartInference)->DenseRange(0, 2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_ChartInferenceMeasure(benchmark::State& state) {
  const Input in = input(static_cast<int>(state.range(0)));
  analysis::MeasureOptions options;
  options.pixel_size_mm = in.maps.pixel_size_mm;
  options.hints.construction = analysis::Construction::knit;
  for (auto _ : state) {
    auto m = analysis::measure_fabric(in.maps.height, in.maps.albedo, options);
    benchmark::DoNotOptimize(m);
  }
}
BENCHMARK(BM_ChartInferenceMeasure)->DenseRange(0, 2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
