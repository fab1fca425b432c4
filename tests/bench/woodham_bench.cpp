// BM_Woodham3/12MP: three 16-bit RGB frames of 4056x3040 -> p, q, RGB
// albedo (and the residual and flags that come with them), against
// BM_StreamCopy/12MP: the same bytes read and written, nothing computed.
// Report Woodham3's throughput as a ratio of StreamCopy's.

#include <cstdlib>
#include <cstring>
#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include <benchmark/benchmark.h>

#include "psrig/base/parallel.h"
#include "psrig/processing/woodham.h"
#include "stream_copy.h"

namespace {

using psrig::formats::Scan;

const Scan& frames_12mp() {
  return psrig::test::stream_copy_scan();
}

std::size_t input_bytes(const Scan& scan) {
  std::size_t bytes = 0;
  for (const auto& frame : scan.frames)
    bytes += frame.total() * frame.elemSize();
  return bytes;
}

std::size_t output_bytes_per_pixel() {
  return psrig::test::solve_output_bytes_per_pixel();
}

void BM_Woodham3(benchmark::State& state) {
  const Scan& scan = frames_12mp();
  psrig::processing::SolveResult result;  // reused, as StreamCopy reuses its output
  for (auto _ : state) {
    if (auto ok = psrig::processing::solve_into(scan, {}, result); !ok)
      state.SkipWithError(ok.error().describe().c_str());
    benchmark::DoNotOptimize(result.p.data);
  }
  const std::size_t pixels = scan.size().area();
  state.SetBytesProcessed(static_cast<int64_t>(
      state.iterations() * (input_bytes(scan) + pixels * output_bytes_per_pixel())));
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * pixels));
}

// Same rows on the same pool: each row reads its input bytes once (three
// frame rows) and writes its output bytes once, copying input to output.
void BM_StreamCopy(benchmark::State& state) {
  const Scan& scan = frames_12mp();
  const cv::Size size = scan.size();
  std::vector<unsigned char> output;
  psrig::test::stream_copy(scan, output);  // the output made and touched before timing
  for (auto _ : state) {
    psrig::test::stream_copy(scan, output);
    benchmark::DoNotOptimize(output.data());
    benchmark::ClobberMemory();
  }
  const std::size_t pixels = size.area();
  state.SetBytesProcessed(static_cast<int64_t>(
      state.iterations() * (input_bytes(scan) + pixels * output_bytes_per_pixel())));
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * pixels));
}

#if defined(__x86_64__)
// The same copy with the advantage the solve takes: non-temporal stores (no
// read of each output line before it is written). The fairest floor for
// Woodham3; StreamCopy is the plain one.
void BM_StreamCopyNonTemporal(benchmark::State& state) {
  const Scan& scan = frames_12mp();
  const cv::Size size = scan.size();
  const std::size_t out_row =
      static_cast<std::size_t>(size.width) * output_bytes_per_pixel() / 16 * 16;
  const std::size_t in_row = scan.frames[0].cols * scan.frames[0].elemSize();
  const std::size_t bytes = out_row * size.height;
  auto* output = static_cast<unsigned char*>(std::aligned_alloc(64, (bytes + 63) / 64 * 64));
  for (auto _ : state) {
    psrig::parallel_chunks(size.height, 8, [&](int begin, int end) {
      for (int r = begin; r < end; ++r) {
        auto* out = reinterpret_cast<__m128i*>(output + out_row * r);
        std::size_t written = 0;
        for (int k = 0; written < out_row; k = (k + 1) % 3) {
          const std::size_t n = std::min(in_row, out_row - written) / 16;
          const auto* in = reinterpret_cast<const __m128i*>(scan.frames[k].ptr(r));
          for (std::size_t i = 0; i < n; ++i)
            _mm_stream_si128(out + written / 16 + i, _mm_loadu_si128(in + i));
          written += 16 * n;
        }
      }
      _mm_sfence();
    });
    benchmark::DoNotOptimize(output);
    benchmark::ClobberMemory();
  }
  std::free(output);
  const std::size_t pixels = size.area();
  state.SetBytesProcessed(static_cast<int64_t>(
      state.iterations() * (input_bytes(scan) + pixels * output_bytes_per_pixel())));
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * pixels));
}
BENCHMARK(BM_StreamCopyNonTemporal)
    ->Name("BM_StreamCopyNonTemporal/12MP")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(2);
#endif

BENCHMARK(BM_Woodham3)
    ->Name("BM_Woodham3/12MP")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(2);
BENCHMARK(BM_StreamCopy)
    ->Name("BM_StreamCopy/12MP")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(2);

}  // namespace
