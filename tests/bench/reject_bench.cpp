// BM_Woodham8Reject/12MP: the solve with outlier rejection (--reject) of
// eight 16-bit RGB frames of 4056x3040 (a glossy sphere: Lambertian plus a
// Blinn-Phong lobe, so highlights are found and dropped), against
// BM_Woodham8/12MP: plain least squares of the same scan. The `x_plain`
// counter is Reject's time over plain least squares', both timed in the same
// iterations, one after the other, so that both see the same machine (the
// goal is at most 3); `x_plain_cpu` the same ratio of the process's CPU
// time (all threads), steadier than wall time on a machine others share.

#include <benchmark/benchmark.h>

#include "bench_sizes.h"
#include "bench_timing.h"
#include "psrig/processing/woodham.h"
#include "synthetic_scene.h"

namespace {

using psrig::formats::Scan;

using psrig::bench::k12MP;
using psrig::bench::timed;
using psrig::bench::Times;

const Scan& scan_8_lights_12mp() {
  static const Scan scan = [] {
    const auto surface = psrig::test::sphere_surface(k12MP, k12MP.height * 0.45, 3);
    return psrig::test::render_scan(surface, psrig::test::dome_lights(8, 55), CV_16U, 0.002, 1, {},
                                    {.strength = 0.5, .exponent = 40});
  }();
  return scan;
}

Times solve_ms(const Scan& scan, const psrig::processing::SolveOptions& options,
               psrig::processing::SolveResult& result, benchmark::State& state) {
  return timed([&] {
    if (auto ok = psrig::processing::solve_into(scan, options, result); !ok)
      state.SkipWithError(ok.error().describe().c_str());
    benchmark::DoNotOptimize(result.p.data);
  });
}

void BM_Woodham8(benchmark::State& state) {
  const Scan& scan = scan_8_lights_12mp();
  psrig::processing::SolveResult result;  // reused, as the rig's pipeline reuses it
  solve_ms(scan, {}, result, state);      // warm up
  for (auto _ : state)
    solve_ms(scan, {}, result, state);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * scan.size().area()));
}

// Each iteration: the rejecting solve (timed), then plain least squares
// (timed apart, not part of the benchmark's time).
void BM_Woodham8Reject(benchmark::State& state) {
  const Scan& scan = scan_8_lights_12mp();
  psrig::processing::SolveResult result, plain_result;
  const psrig::processing::SolveOptions reject{.reject_outliers = true};
  solve_ms(scan, reject, result, state);
  solve_ms(scan, {}, plain_result, state);
  Times rejecting, plain;
  for (auto _ : state) {
    rejecting += solve_ms(scan, reject, result, state);
    state.PauseTiming();
    plain += solve_ms(scan, {}, plain_result, state);
    state.ResumeTiming();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * scan.size().area()));
  if (plain.wall_ms > 0) state.counters["x_plain"] = rejecting.wall_ms / plain.wall_ms;
  if (plain.cpu_ms > 0) state.counters["x_plain_cpu"] = rejecting.cpu_ms / plain.cpu_ms;
}

BENCHMARK(BM_Woodham8)
    ->Name("BM_Woodham8/12MP")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(4);
BENCHMARK(BM_Woodham8Reject)
    ->Name("BM_Woodham8Reject/12MP")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(4);

}  // namespace
