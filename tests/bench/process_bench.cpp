// BM_Process/12MP: `psrig process` of a 12.3 MP (4056x3040) three-light
// 16-bit colour scan, files to files, as the rig writes it (frames only, no
// ground truth), into a fresh maps directory each time. Against
// BM_FileCopy/12MP: reading the same input files and writing the same
// number of output bytes with plain read/write, the I/O floor.
//
// BM_Process/12MP_knit: what `psrig synth --size 4000x3000` writes, a
// jersey knit under the rig's three LEDs at 45 degrees with its cast
// shadows and its ground truth: the user's 12 MP knit, for which `auto`
// integration takes the masked least-squares path (the label says which
// ran; a knit that did not would be an error). The issue-28 goals, 3 s and
// 512 MB on a 2-core machine, are this benchmark's, never a test's.
//
// Both count `peak_rss_MB` (the most the process held while processing,
// sampled every millisecond: base/memory_use.h, the benchmark's own scans
// included) and `rss_growth_MB` (that above what it held before: what
// processing adds to psrig process's ~60 MB at start); `x_stream_copy`, the
// processing's time over
// BM_StreamCopy/12MP's copy timed in the same iterations right after it
// (stream_copy.h), and `x_stream_copy_cpu` the same for the process's CPU
// time, steadier on a machine others share.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "bench_timing.h"
#include "psrig/base/memory_use.h"
#include "psrig/formats/scan_writer.h"
#include "psrig/processing/pipeline.h"
#include "psrig/sim/synthetic_scan.h"
#include "shipped_swatch.h"
#include "stream_copy.h"
#include "test_support.h"

namespace {

namespace fs = std::filesystem;
using psrig::bench::timed;
using psrig::bench::Times;

const psrig::test::TempDir& workspace() {
  static const psrig::test::TempDir dir("psrig-bench-process");
  return dir;
}

// A synthetic scan written once per benchmark run (about ten seconds).
fs::path write_synthetic(const std::string& name, psrig::sim::SyntheticScanParams params,
                         bool ground_truth) {
  psrig::formats::Scan synthetic = psrig::test::made(psrig::sim::make_synthetic_scan(params));
  if (!ground_truth) {  // a rig scan has none
    synthetic.ground_truth_normal = cv::Mat();
    synthetic.ground_truth_height = cv::Mat();
  }
  const fs::path dir = workspace() / name;
  if (auto ok = psrig::formats::write_scan(synthetic, dir); !ok)
    std::fprintf(stderr, "%s\n", ok.error().describe().c_str());
  return dir;
}

const fs::path& scan_12mp() {
  static const fs::path scan = [] {
    psrig::sim::SyntheticScanParams params;
    params.swatch.pattern = psrig::test::named_pattern("jersey");
    params.swatch.size = {4056, 3040};
    params.noise = 0.002;
    return write_synthetic("scan", params, false);
  }();
  return scan;
}

// psrig synth's defaults (apps/psrig/synth_command.cpp) at 4000x3000.
const fs::path& knit_12mp() {
  static const fs::path scan = [] {
    psrig::sim::SyntheticScanParams params;
    params.swatch.pattern = psrig::test::named_pattern("jersey");
    params.swatch.size = {4000, 3000};
    return write_synthetic("knit", params, true);
  }();
  return scan;
}

std::size_t directory_bytes(const fs::path& dir) {
  std::size_t bytes = 0;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.is_regular_file()) bytes += entry.file_size();
  return bytes;
}

std::size_t maps_bytes = 0;  // measured by BM_Process, used by BM_FileCopy

double megabytes(std::size_t bytes) {
  return static_cast<double>(bytes) / (1 << 20);
}

// Processes `scan` with `storage`'s compression; counts the bytes of the
// maps (output_MB), of the frames (input_MB) and of both (stored_MB), the
// memory and the ratios to the stream copy (above). `method`: the
// integration a knit must take, or empty.
void process_12mp(benchmark::State& state, const fs::path& scan,
                  const psrig::formats::StorageOptions& storage, const std::string& method = {}) {
  psrig::processing::ProcessOptions options;
  options.storage = storage;
  options.output = workspace() / "maps";
  const psrig::formats::Scan& copied = psrig::test::stream_copy_scan();
  std::vector<unsigned char> copy;
  psrig::test::stream_copy(copied, copy);  // made and touched before timing
  Times processing, copying;
  double peak_mb = 0, growth_mb = 0;
  std::string ran;
  psrig::ResidentSampler sampler(std::chrono::milliseconds(1));
  for (auto _ : state) {
    state.PauseTiming();
    fs::remove_all(options.output);
    const double before_mb = megabytes(psrig::resident_bytes());
    (void)sampler.take_peak();
    state.ResumeTiming();
    std::optional<psrig::Result<psrig::processing::ProcessSummary>> summary;
    const Times t = timed([&] { summary = psrig::processing::process_scan(scan, options); });
    state.PauseTiming();
    const double peak = megabytes(sampler.take_peak());
    peak_mb = std::max(peak_mb, peak);
    growth_mb = std::max(growth_mb, peak - before_mb);
    if (!*summary) {
      state.SkipWithError(summary->error().describe().c_str());
      break;
    }
    processing.wall_ms += t.wall_ms, processing.cpu_ms += t.cpu_ms;
    const Times c = timed([&] { psrig::test::stream_copy(copied, copy); });
    copying.wall_ms += c.wall_ms, copying.cpu_ms += c.cpu_ms;
    const auto& report = (**summary).report;
    ran = report.contains("height") ? report["height"]["method"].get<std::string>() : "none";
    state.ResumeTiming();
  }
  if (!method.empty() && ran != method && !ran.empty())
    state.SkipWithError(("integration took the " + ran + " path, not " + method).c_str());
  state.SetLabel("integration " + ran);
  maps_bytes = directory_bytes(options.output);
  state.counters["output_MB"] = static_cast<double>(maps_bytes) / 1e6;
  state.counters["input_MB"] = static_cast<double>(directory_bytes(scan)) / 1e6;
  state.counters["stored_MB"] = static_cast<double>(maps_bytes + directory_bytes(scan)) / 1e6;
  state.counters["peak_rss_MB"] = peak_mb;
  state.counters["rss_growth_MB"] = growth_mb;
  if (copying.wall_ms > 0) state.counters["x_stream_copy"] = processing.wall_ms / copying.wall_ms;
  if (copying.cpu_ms > 0) state.counters["x_stream_copy_cpu"] = processing.cpu_ms / copying.cpu_ms;
}

// The defaults, as `psrig process` and rig.toml's [storage] give them.
void BM_Process(benchmark::State& state) {
  process_12mp(state, scan_12mp(), {});
}

// The user's knit, with its shadows: the masked path.
void BM_ProcessKnit(benchmark::State& state) {
  process_12mp(state, knit_12mp(), {}, "masked");
}

// The other choices, for picking the defaults by bytes and time.
void BM_ProcessExr(benchmark::State& state) {
  psrig::formats::StorageOptions storage;
  storage.exr_compression = static_cast<psrig::formats::ExrCompression>(state.range(0));
  storage.png_level = static_cast<int>(state.range(1));
  storage.map_precision = static_cast<psrig::formats::MapPrecision>(state.range(2));
  state.SetLabel(std::string("exr ") + to_string(storage.exr_compression) + ", png level " +
                 std::to_string(storage.png_level) + ", maps " + to_string(storage.map_precision));
  process_12mp(state, scan_12mp(), storage);
}

void BM_FileCopy(benchmark::State& state) {
  const fs::path& scan = scan_12mp();
  const fs::path out = workspace() / "copy";
  std::vector<char> buffer(1 << 20);
  for (auto _ : state) {
    state.PauseTiming();
    fs::remove_all(out);
    fs::create_directory(out);
    state.ResumeTiming();
    for (const auto& entry : fs::directory_iterator(scan)) {
      std::ifstream in(entry.path(), std::ios::binary);
      while (in.read(buffer.data(), static_cast<std::streamsize>(buffer.size())) || in.gcount() > 0)
        benchmark::DoNotOptimize(buffer.data());
    }
    std::ofstream file(out / "maps.bin", std::ios::binary);
    for (std::size_t written = 0; written < maps_bytes; written += buffer.size())
      file.write(buffer.data(),
                 static_cast<std::streamsize>(std::min(buffer.size(), maps_bytes - written)));
  }
}

constexpr int kHalf = static_cast<int>(psrig::formats::MapPrecision::half);
constexpr int kFloat = static_cast<int>(psrig::formats::MapPrecision::full);

BENCHMARK(BM_Process)
    ->Name("BM_Process/12MP")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(5);
BENCHMARK(BM_ProcessKnit)
    ->Name("BM_Process/12MP_knit")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(5);
BENCHMARK(BM_FileCopy)
    ->Name("BM_FileCopy/12MP")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(5);

BENCHMARK(BM_ProcessExr)
    ->Name("BM_ProcessStorage/12MP")
    ->Args({static_cast<int>(psrig::formats::ExrCompression::none), 1, kHalf})
    ->Args({static_cast<int>(psrig::formats::ExrCompression::zip), 1, kHalf})
    ->Args({static_cast<int>(psrig::formats::ExrCompression::piz), 1, kHalf})
    ->Args({static_cast<int>(psrig::formats::ExrCompression::automatic), 6, kHalf})
    // The maps before half precision: the same run's baseline.
    ->Args({static_cast<int>(psrig::formats::ExrCompression::automatic), 1, kFloat})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(2);

}  // namespace
