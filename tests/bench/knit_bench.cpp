// The cloth's per-frame yarn update (issue 18's goal: 10 K stitches in
// under 5 ms on the 2-core machine), at 1 K, 10 K and 50 K stitches,
// stretched and sheared a little differently every frame:
//   BM_KnitUpdate/<stitches>/<chart>: stockinette (chart 0) and
//     basketweave (1, an 8 x 8 repeat): the relaxed repeat blended from its
//     table (relaxed once, before timing) and placed on the mesh;
//   BM_KnitRelaxRepeat/<chart>: one relaxation of the repeat, the cost of a
//     deformation the table has not seen.
// Report the update's absolute time and BM_KnitUpdate's ratio between the
// two charts from the same run.

#include <cmath>
#include <filesystem>
#include <vector>

#include <benchmark/benchmark.h>

#include "psrig/cloth/knit_fabric.h"
#include "psrig/cloth/stitch_cloth.h"

namespace {

using namespace psrig::cloth;

StitchChart chart(int which) {
  auto loaded = load_stitch_chart(std::filesystem::path(PSRIG_SOURCE_DIR) / "config/patterns" /
                                  (which == 0 ? "stockinette.chart" : "basketweave.chart"));
  return loaded ? *loaded : StitchChart{};
}

void BM_KnitUpdate(benchmark::State& state) {
  const int side = static_cast<int>(std::lround(std::sqrt(static_cast<double>(state.range(0)))));
  auto fabric = KnitFabric::build(chart(static_cast<int>(state.range(1))), side, side, {});
  if (!fabric) {
    state.SkipWithError(fabric.error().describe().c_str());
    return;
  }
  // Deformations that change every frame, within one cell of the table.
  std::vector<StitchMesh> meshes;
  for (int i = 0; i < 8; ++i)
    meshes.push_back(fabric->mesh({1.15f + 0.1f * std::sin(0.7f * i), 0.1f * std::cos(0.7f * i)}));
  YarnSet yarns;
  for (const StitchMesh& mesh : meshes) fabric->update(mesh, yarns);  // the table's nodes
  int frame = 0;
  for (auto _ : state) {
    fabric->update(meshes[static_cast<std::size_t>(frame++ % 8)], yarns);
    benchmark::DoNotOptimize(yarns.curves.data());
  }
  state.counters["stitches"] = side * side;
  state.counters["points"] = static_cast<double>(yarns.point_count());
}

void BM_KnitRelaxRepeat(benchmark::State& state) {
  const StitchChart pattern = chart(static_cast<int>(state.range(0)));
  const auto dimensions = resolve_knit_gauge({});
  const YarnCell rest =
      knit_rest_cell(pattern, *dimensions, knit_repeat_layout(pattern, *dimensions, false));
  Eigen::Matrix2f deformation;
  deformation << 1.25f, 0.125f, 0, 1;
  for (auto _ : state) {
    YarnCell cell = deform_cell(rest, deformation);
    benchmark::DoNotOptimize(relax_cell(cell, rest, deformation));
  }
}

// Issue 19's goal: one frame of the stitch-level simulation plus the yarns
// following it, 10 K stitches, under 3 ms. A swatch hanging from its top
// edge over a sphere, stepped at 60 frames a second.
void BM_DrapeStep(benchmark::State& state) {
  const int side = static_cast<int>(std::lround(std::sqrt(static_cast<double>(state.range(0)))));
  auto fabric = KnitFabric::build(chart(0), side, side, {});
  if (!fabric) {
    state.SkipWithError(fabric.error().describe().c_str());
    return;
  }
  const bool with_yarns = state.range(1) != 0;
  StitchMesh rest = fabric->mesh();
  for (Eigen::Vector3f& v : rest.vertices) v = {v.x(), 0, v.y()};  // hanging in the x-z plane
  StitchCloth cloth(rest, {});
  for (int column = 0; column <= rest.columns; ++column) cloth.pin(column, rest.rows);
  cloth.colliders = {SphereCollider{{0, 8, 0}, 10}};
  YarnSet yarns;
  for (int frame = 0; frame < 5; ++frame) cloth.step(1.0f / 60);  // the factorisation, once
  for (auto _ : state) {
    cloth.step(1.0f / 60);
    if (with_yarns) fabric->update(cloth.mesh(), yarns);
    benchmark::DoNotOptimize(cloth.mesh().vertices.data());
  }
  state.counters["stitches"] = side * side;
}

BENCHMARK(BM_DrapeStep)
    ->ArgsProduct({{1000, 10000, 50000}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

BENCHMARK(BM_KnitUpdate)
    ->ArgsProduct({{1000, 10000, 50000}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_KnitRelaxRepeat)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
