#pragma once
// The process's one thread pool. It is OpenCV's (TBB on Debian); FFTW's
// threads are routed into it too (see integration), so `--threads N` bounds
// every parallel loop in the program.

#include <functional>

namespace psrig {

// 0 means one thread per hardware thread; more than that is capped to it.
void set_thread_count(int threads);
[[nodiscard]] int thread_count();

// Calls body(begin, end) on the pool for the consecutive chunks [begin, end)
// of [0, count), `chunk` items each (the last may be shorter). Chunk
// boundaries depend only on count and chunk, never on the thread count, so a
// reduction done per chunk and combined in chunk order is reproducible.
void parallel_chunks(int count, int chunk, const std::function<void(int begin, int end)>& body);

[[nodiscard]] inline int chunk_count(int count, int chunk) {
  return (count + chunk - 1) / chunk;
}

}  // namespace psrig
