// Normal integration at the rig's full resolution, 4056 x 3040 (12.3 MP),
// against the cost of the FFTW transforms it is built on.
//   BM_FftPair/12MP: one forward (2-D REDFT10) and one inverse (2-D REDFT01)
//     transform of that size, planned once outside the timed loop with the
//     thread setup the library uses.
//   BM_FrankotChellappa/12MP: three such transforms plus the pointwise work;
//     the goal is within 2.5x BM_FftPair.
//   BM_Poisson/12MP: two transforms plus the pointwise work.
//   BM_MaskedIntegration/12MP: least squares over a mask (an ellipse filling
//     the frame, with a grid of round holes, as a piece of lace): conjugate
//     gradients with a multigrid V-cycle, to the default tolerance; the goal
//     is within 4x BM_FftPair. Its counter `iterations` is the CG count.

#include <cmath>
#include <cstddef>
#include <cstring>
#include <mutex>

#include <benchmark/benchmark.h>
#include <fftw3.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "bench_sizes.h"
#include "psrig/base/parallel.h"
#include "psrig/processing/integration.h"

namespace {

using psrig::bench::kHeight;
using psrig::bench::kWidth;
constexpr std::int64_t kPixels = static_cast<std::int64_t>(kWidth) * kHeight;

// A smooth field with some texture: the transforms' cost does not depend on
// the values, but the numbers stay finite and realistic.
void make_gradients(cv::Mat& p, cv::Mat& q) {
  p.create(kHeight, kWidth, CV_32F);
  q.create(kHeight, kWidth, CV_32F);
  psrig::parallel_chunks(kHeight, 16, [&](int begin, int end) {
    for (int row = begin; row < end; ++row) {
      auto* p_row = p.ptr<float>(row);
      auto* q_row = q.ptr<float>(row);
      for (int col = 0; col < kWidth; ++col) {
        p_row[col] = 0.3F * std::sin(0.011F * static_cast<float>(col)) +
                     0.05F * std::cos(0.7F * static_cast<float>(col + row));
        q_row[col] = 0.2F * std::cos(0.007F * static_cast<float>(row)) +
                     0.05F * std::sin(0.9F * static_cast<float>(col - row));
      }
    }
  });
}

void BM_FrankotChellappa(benchmark::State& state) {
  cv::Mat p;
  cv::Mat q;
  make_gradients(p, q);
  if (!psrig::processing::integrate_frankot_chellappa(p, q)) {  // warm up: pages, TBB
    state.SkipWithError("integration failed");
    return;
  }
  for (auto _ : state) {
    auto z = psrig::processing::integrate_frankot_chellappa(p, q);
    benchmark::DoNotOptimize(z);
  }
  state.SetItemsProcessed(state.iterations() * kPixels);
}

void BM_Poisson(benchmark::State& state) {
  cv::Mat p;
  cv::Mat q;
  make_gradients(p, q);
  if (!psrig::processing::integrate_poisson(p, q)) {
    state.SkipWithError("integration failed");
    return;
  }
  for (auto _ : state) {
    auto z = psrig::processing::integrate_poisson(p, q);
    benchmark::DoNotOptimize(z);
  }
  state.SetItemsProcessed(state.iterations() * kPixels);
}

cv::Mat make_mask() {
  cv::Mat mask(kHeight, kWidth, CV_8U, cv::Scalar(0));
  cv::ellipse(mask, cv::Point(kWidth / 2, kHeight / 2), cv::Size(kWidth / 2 - 8, kHeight / 2 - 8),
              0.0, 0.0, 360.0, cv::Scalar(255), cv::FILLED);
  for (int y = 200; y < kHeight; y += 400)
    for (int x = 200; x < kWidth; x += 400)
      cv::circle(mask, cv::Point(x, y), 90, cv::Scalar(0), cv::FILLED);
  return mask;
}

void BM_MaskedIntegration(benchmark::State& state) {
  cv::Mat p;
  cv::Mat q;
  make_gradients(p, q);
  const cv::Mat mask = make_mask();
  psrig::processing::MaskedIntegrationStats stats;
  if (!psrig::processing::integrate_masked(p, q, mask, {}, &stats)) {
    state.SkipWithError("integration failed");
    return;
  }
  for (auto _ : state) {
    auto z = psrig::processing::integrate_masked(p, q, mask, {}, &stats);
    benchmark::DoNotOptimize(z);
  }
  state.counters["iterations"] = stats.iterations;
  state.counters["residual"] = stats.relative_residual;
  state.SetItemsProcessed(state.iterations() * kPixels);
}

void BM_FftPair(benchmark::State& state) {
  psrig::processing::prepare_fftw_threads();  // the same thread setup as the integrators
  const std::size_t pixels = static_cast<std::size_t>(kPixels);
  float* buffer = fftwf_alloc_real(pixels);
  fftwf_plan_with_nthreads(psrig::thread_count());
  fftwf_plan forward =
      fftwf_plan_r2r_2d(kHeight, kWidth, buffer, buffer, FFTW_REDFT10, FFTW_REDFT10, FFTW_ESTIMATE);
  fftwf_plan inverse =
      fftwf_plan_r2r_2d(kHeight, kWidth, buffer, buffer, FFTW_REDFT01, FFTW_REDFT01, FFTW_ESTIMATE);
  cv::Mat p;
  cv::Mat q;
  make_gradients(p, q);
  std::memcpy(buffer, p.ptr<float>(), pixels * sizeof(float));
  for (auto _ : state) {
    fftwf_execute(forward);
    fftwf_execute(inverse);
    benchmark::DoNotOptimize(buffer[0]);
    benchmark::ClobberMemory();
    // The pair scales by 4WH; rescale outside the timing so values stay put.
    state.PauseTiming();
    const float scale = 1.0F / (4.0F * static_cast<float>(pixels));
    for (std::size_t i = 0; i < pixels; ++i)
      buffer[i] *= scale;
    state.ResumeTiming();
  }
  state.SetItemsProcessed(state.iterations() * kPixels);
  fftwf_destroy_plan(forward);
  fftwf_destroy_plan(inverse);
  fftwf_free(buffer);
}

}  // namespace

BENCHMARK(BM_FrankotChellappa)
    ->Name("BM_FrankotChellappa/12MP")
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Poisson)->Name("BM_Poisson/12MP")->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MaskedIntegration)
    ->Name("BM_MaskedIntegration/12MP")
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FftPair)->Name("BM_FftPair/12MP")->UseRealTime()->Unit(benchmark::kMillisecond);
