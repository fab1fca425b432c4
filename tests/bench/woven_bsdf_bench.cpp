// The fabric shading model and its footprint aggregation (issue 31, chen2024
// 3.1 and 5.1), what the neural woven BSDF's data budget is planned from:
//   BM_WovenPointBsdf: eq. (1)-(2) at one point, specular and diffuse, per
//     evaluation;
//   BM_WovenSurfacePoint: the yarn, n_p, t_p and height at one point;
//   BM_WovenAggregate/<size in 1/10 repeats>: one query from scratch, 2048
//     samples (the paper's ground truth): the points, V towards wi and wo,
//     eq. (3);
//   BM_WovenDatasetFootprint/<threads>/<direction grid>: two footprints
//     (one under a repeat, one over) of the data set generator, 2048
//     samples shared by their direction pairs (grid 8: 8 x 8 strata each
//     way, ~2500 pairs, chen2024's; grid 4: ~150); items/s is queries a
//     second, the time is two footprints'. A material is 1280 footprints.
// Patterns: the 5-harness satin (a long float, the most shadowing) with u
// = 30, alpha = 0.5, beta = 1.

#include <cmath>
#include <random>
#include <vector>

#include <benchmark/benchmark.h>

#include "psrig/base/parallel.h"
#include "psrig/cloth/weave_rules.h"
#include "psrig/cloth/woven_aggregate.h"
#include "psrig/cloth/woven_dataset_generator.h"

namespace {

using namespace psrig::cloth;

WovenSurface bench_surface() {
  auto surface = WovenSurface::make(satin_weave(5, 2), {}, 1, 1);
  return std::move(*surface);
}

Eigen::Vector3f front_direction(std::mt19937& random) {
  std::uniform_real_distribution<float> disc(-1, 1);
  while (true) {
    const float x = disc(random), y = disc(random);
    if (x * x + y * y < 0.98f) return {x, y, std::sqrt(1 - x * x - y * y)};
  }
}

void BM_WovenPointBsdf(benchmark::State& state) {
  std::mt19937 random(1);
  const WovenSurface surface = bench_surface();
  struct PointBsdfInput {
    Eigen::Vector3f wi, wo;
    WovenPoint p;
  };
  std::vector<PointBsdfInput> inputs;
  std::uniform_real_distribution<float> position(0, 5);
  while (inputs.size() < 1024) {
    const WovenPoint p = surface.point({position(random), position(random)});
    if (p.yarn != YarnType::gap)
      inputs.push_back({front_direction(random), front_direction(random), p});
  }
  std::size_t k = 0;
  for (auto _ : state) {
    const PointBsdfInput& in = inputs[k++ & 1023];
    benchmark::DoNotOptimize(woven_specular(in.wi, in.wo, in.p.normal, in.p.orientation, 0.5f) +
                             woven_diffuse(in.wi, in.wo, in.p.normal));
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_WovenSurfacePoint(benchmark::State& state) {
  const WovenSurface surface = bench_surface();
  float x = 0.1f;
  for (auto _ : state) {
    x += 0.0137f;
    benchmark::DoNotOptimize(surface.point({x, 0.37f * x}));
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_WovenAggregate(benchmark::State& state) {
  const WovenSurface surface = bench_surface();
  const WovenShading shading{};
  const float size = static_cast<float>(state.range(0)) / 10;
  std::mt19937 random(2);
  std::uint64_t seed = 0;
  for (auto _ : state) {
    const Eigen::Vector3f wi = front_direction(random), wo = front_direction(random);
    benchmark::DoNotOptimize(aggregate_woven_bsdf(
        surface, shading, footprint_in_repeats(surface, 0.3f, 0.6f, size), wi, wo, 2048, ++seed));
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_WovenDatasetFootprint(benchmark::State& state) {
  const int threads = psrig::thread_count();
  psrig::set_thread_count(static_cast<int>(state.range(0)));
  WovenDatasetOptions options;
  options.direction_grid = static_cast<int>(state.range(1));
  options.centre_grid = 1;
  options.small_sizes = 1;
  options.large_sizes = 1;  // two footprints: one small, one large
  WovenMaterialParameters parameters;
  std::uint64_t seed = 0;
  std::int64_t queries = 0;
  for (auto _ : state) {
    auto made = generate_woven_queries(satin_weave(5, 2), parameters, 0, options, ++seed);
    queries += made ? static_cast<std::int64_t>(made->size()) : 0;
    benchmark::DoNotOptimize(made);
  }
  state.SetItemsProcessed(queries);
  psrig::set_thread_count(threads);
}

}  // namespace

BENCHMARK(BM_WovenPointBsdf);
BENCHMARK(BM_WovenSurfacePoint);
BENCHMARK(BM_WovenAggregate)->Arg(1)->Arg(10)->Arg(50)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_WovenDatasetFootprint)
    ->Args({1, 4})
    ->Args({1, 8})
    ->Args({2, 8})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
