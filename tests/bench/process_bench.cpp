// BM_Process/12MP: `psrig process` of a 12.3 MP (4056x3040) three-light
// 16-bit colour scan, files to files, as the rig writes it (frames only, no
// ground truth), into a fresh maps directory each time. Against
// BM_FileCopy/12MP: reading the same input files and writing the same
// number of output bytes with plain read/write, the I/O floor.

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "psrig/formats/scan_writer.h"
#include "psrig/processing/pipeline.h"
#include "psrig/sim/synthetic_scan.h"
#include "shipped_swatch.h"
#include "test_support.h"

namespace {

namespace fs = std::filesystem;

const psrig::test::TempDir& workspace() {
  static const psrig::test::TempDir dir("psrig-bench-process");
  return dir;
}

// Written once per benchmark run; about ten seconds.
const fs::path& scan_12mp() {
  static const fs::path scan = [] {
    psrig::sim::SyntheticScanParams params;
    params.swatch.pattern = psrig::test::named_pattern("jersey");
    params.swatch.size = {4056, 3040};
    params.noise = 0.002;
    psrig::formats::Scan synthetic = psrig::test::made(psrig::sim::make_synthetic_scan(params));
    synthetic.ground_truth_normal = cv::Mat();  // a rig scan has none
    synthetic.ground_truth_height = cv::Mat();
    const fs::path dir = workspace() / "scan";
    if (auto ok = psrig::formats::write_scan(synthetic, dir); !ok)
      std::fprintf(stderr, "%s\n", ok.error().describe().c_str());
    return dir;
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

// Processes the 12 MP scan with `storage`'s compression; counts the bytes
// of the maps (output_MB), of the frames (input_MB) and of both (stored_MB).
void process_12mp(benchmark::State& state, const psrig::formats::StorageOptions& storage) {
  const fs::path& scan = scan_12mp();
  psrig::processing::ProcessOptions options;
  options.storage = storage;
  options.output = workspace() / "maps";
  for (auto _ : state) {
    state.PauseTiming();
    fs::remove_all(options.output);
    state.ResumeTiming();
    auto summary = psrig::processing::process_scan(scan, options);
    if (!summary) state.SkipWithError(summary.error().describe().c_str());
  }
  maps_bytes = directory_bytes(options.output);
  state.counters["output_MB"] = static_cast<double>(maps_bytes) / 1e6;
  state.counters["input_MB"] = static_cast<double>(directory_bytes(scan)) / 1e6;
  state.counters["stored_MB"] = static_cast<double>(maps_bytes + directory_bytes(scan)) / 1e6;
}

// The defaults, as `psrig process` and rig.toml's [storage] give them.
void BM_Process(benchmark::State& state) {
  process_12mp(state, {});
}

// The other choices, for picking the defaults by bytes and time.
void BM_ProcessExr(benchmark::State& state) {
  psrig::formats::StorageOptions storage;
  storage.exr_compression = static_cast<psrig::formats::ExrCompression>(state.range(0));
  storage.png_level = static_cast<int>(state.range(1));
  storage.map_precision = static_cast<psrig::formats::MapPrecision>(state.range(2));
  state.SetLabel(std::string("exr ") + to_string(storage.exr_compression) + ", png level " +
                 std::to_string(storage.png_level) + ", maps " + to_string(storage.map_precision));
  process_12mp(state, storage);
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
