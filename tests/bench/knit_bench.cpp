// The knit cloth's per-frame yarn update (issue 5's goal: 10 K stitches in
// 5 ms on the 2-core machine), at 1 K, 10 K and 50 K stitches of
// stockinette, stretched and sheared:
//   BM_KnitCarried: knots carried by each face's deformation gradient and the
//     yarns sampled, no relaxation (the baseline);
//   BM_KnitRelaxed: the same plus three Gauss-Newton iterations per knot.
// Report BM_KnitRelaxed / BM_KnitCarried from the same run as well as the
// absolute time.

#include <cmath>
#include <vector>

#include <benchmark/benchmark.h>

#include "psrig/cloth/knit_fabric.h"

namespace {

using namespace psrig::cloth;

void knit_update(benchmark::State& state, bool relax) {
  const int side = static_cast<int>(std::lround(std::sqrt(static_cast<double>(state.range(0)))));
  const KnitLayout layout{
      side, side, std::vector<std::uint8_t>(static_cast<std::size_t>(side * side), 0), {}};
  KnitFabric fabric = KnitFabric::build(layout, {});
  // Two deformations in turn, so every update has work to do.
  const StitchMesh meshes[2] = {fabric.mesh({1.3f, 0.2f}), fabric.mesh({1.25f, 0.15f})};
  YarnSet yarns;
  fabric.update(meshes[1], yarns, relax);
  int frame = 0;
  for (auto _ : state) {
    fabric.update(meshes[frame++ % 2], yarns, relax);
    benchmark::DoNotOptimize(yarns.curves.data());
  }
  state.counters["stitches"] = side * side;
  state.counters["points"] = static_cast<double>(yarns.point_count());
}

void BM_KnitCarried(benchmark::State& state) {
  knit_update(state, false);
}
void BM_KnitRelaxed(benchmark::State& state) {
  knit_update(state, true);
}

BENCHMARK(BM_KnitCarried)
    ->Arg(1000)
    ->Arg(10000)
    ->Arg(50000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_KnitRelaxed)
    ->Arg(1000)
    ->Arg(10000)
    ->Arg(50000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
