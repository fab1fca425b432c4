#include "psrig/base/parallel.h"

#include <algorithm>
#include <thread>

#include <opencv2/core.hpp>

namespace psrig {

void set_thread_count(int threads) {
  // More threads than hardware threads only adds switching (and TBB refuses
  // them with a warning), so requests are capped.
  const int hardware = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  cv::setNumThreads(threads <= 0 ? hardware : std::min(threads, hardware));
}

int thread_count() {
  return std::max(1, cv::getNumThreads());
}

void parallel_chunks(int count, int chunk, const std::function<void(int, int)>& body) {
  if (count <= 0) return;
  chunk = std::max(1, chunk);
  const int chunks = chunk_count(count, chunk);
  if (chunks == 1 || thread_count() == 1) {
    for (int c = 0; c < chunks; ++c)
      body(c * chunk, std::min(count, (c + 1) * chunk));
    return;
  }
  cv::parallel_for_(
      cv::Range(0, chunks),
      [&](const cv::Range& range) {
        for (int c = range.start; c < range.end; ++c)
          body(c * chunk, std::min(count, (c + 1) * chunk));
      },
      chunks);
}

}  // namespace psrig
