// BM_ScanCycle: one acquisition on the simulated rig with config/sim.toml's
// frame timing (dark frame and three LEDs, two frames averaged each, 20 ms
// exposure and 15 ms readout), frames only. Its baseline is the sum of the
// exposures and readouts of the frames kept, which a perfect sequencer on
// this camera could not beat; the `overhead` counter is the time over that,
// as a fraction of it (goal: at most 0.10). BM_ScanCycle/short_gap has a
// readout gap too short to switch an LED in, so one frame per switch is
// lost: the cost of the stale-frame rule without the timed switch.

#include <cstdio>
#include <filesystem>

#include <benchmark/benchmark.h>

#include "psrig/config/config_loader.h"
#include "psrig/rig/rig.h"
#include "psrig/rig/scan_sequencer.h"

namespace {

void BM_ScanCycle(benchmark::State& state, int exposure_us, int readout_us) {
  auto config =
      psrig::config::load_config(std::filesystem::path(PSRIG_SOURCE_DIR) / "config/sim.toml");
  if (!config) {
    state.SkipWithError(config.error().describe().c_str());
    return;
  }
  config->camera.exposure_us = exposure_us;
  config->sim.readout_us = readout_us;
  config->capture.process = false;
  auto rig = psrig::rig::open_rig(*config);
  if (!rig) {
    state.SkipWithError(rig.error().describe().c_str());
    return;
  }
  psrig::rig::ScanSequencer sequencer(*config, *rig->lights, *rig->camera);
  double overhead = 0, skipped = 0;
  for (auto _ : state) {
    psrig::rig::CaptureTiming timing;
    auto scan = sequencer.acquire({}, timing);
    if (!scan) {
      state.SkipWithError(scan.error().describe().c_str());
      return;
    }
    const double frame_ms = (exposure_us + readout_us) / 1000.0;
    overhead += timing.total.count() / (timing.frames_kept * frame_ms) - 1;
    skipped += timing.frames_skipped;
  }
  state.counters["overhead"] = overhead / static_cast<double>(state.iterations());
  state.counters["frames_skipped"] = skipped / static_cast<double>(state.iterations());
}

BENCHMARK_CAPTURE(BM_ScanCycle, sim_toml, 20000, 15000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_ScanCycle, short_gap, 20000, 500)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
