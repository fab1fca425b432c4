// The fabric measurement and the seamless tile on 12 MP maps (4056x3040):
//   BM_MeasureFabric/12MP: what `psrig process` adds per scan (the maps are
//     measured at 1600 pixels a side); compare BM_FftPair/12MP, one
//     full-size transform pair (integration_bench.cpp), in the same run.
//   BM_SeamlessTile/12MP: the lattice plus `psrig tile`'s resampling and
//     cross-fade of every map (not the writing).

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>

#include "bench_sizes.h"
#include "psrig/analysis/fabric_measure.h"
#include "psrig/analysis/seamless_tile.h"
#include "psrig/sim/swatch_model.h"
#include "shipped_swatch.h"

namespace {

using psrig::bench::kHeight;
using psrig::bench::kWidth;

// A jersey rendered at a quarter of the area, repeated to 12 MP: the
// figures' cost depends on the size, not on the seams this leaves.
psrig::formats::Maps jersey_maps() {
  psrig::sim::SwatchParams params = psrig::test::swatch_params("jersey", {kWidth / 2, kHeight / 2});
  params.rotation_deg = 3;
  const psrig::sim::Swatch swatch = psrig::test::made(psrig::sim::make_swatch(params));
  psrig::formats::Maps maps;
  cv::repeat(swatch.height_mm, 2, 2, maps.height);
  cv::repeat(swatch.albedo, 2, 2, maps.albedo);
  cv::Mat n[3];
  cv::split(swatch.normal, n);
  cv::repeat(-n[0] / n[2], 2, 2, maps.p);
  cv::repeat(-n[1] / n[2], 2, 2, maps.q);
  maps.mask = cv::Mat(maps.height.size(), CV_8U, cv::Scalar(255));
  maps.pixel_size_mm = 0.025;
  maps.height_units = "mm";
  return maps;
}

void BM_MeasureFabric(benchmark::State& state) {
  const auto maps = jersey_maps();
  psrig::analysis::MeasureOptions options;
  options.pixel_size_mm = 0.025;
  for (auto _ : state) {
    auto m = psrig::analysis::measure_fabric(maps.height, maps.albedo, options);
    benchmark::DoNotOptimize(m);
  }
}

void BM_SeamlessTile(benchmark::State& state) {
  const auto maps = jersey_maps();
  for (auto _ : state) {
    const auto lattice = psrig::analysis::find_repeat_lattice(maps.height, maps.albedo);
    auto tile = psrig::analysis::make_seamless_tile(maps, lattice);
    benchmark::DoNotOptimize(tile);
  }
}

}  // namespace

BENCHMARK(BM_MeasureFabric)
    ->Name("BM_MeasureFabric/12MP")
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SeamlessTile)
    ->Name("BM_SeamlessTile/12MP")
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
