#pragma once
// The process's memory as Linux counts it (/proc/self), for reports: what
// processing held at most, stage by stage. Elsewhere every figure is 0.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <pthread.h>

namespace psrig {

// Resident set size now, in bytes.
[[nodiscard]] std::size_t resident_bytes();

// The most resident at any moment since the process started (VmHWM, what
// getrusage's ru_maxrss and `time -v` report).
[[nodiscard]] std::size_t peak_resident_bytes();

// The resident size looked at every `interval` on a thread of its own, so
// that a part of the program can be given its own peak (the process's
// peak, which the kernel keeps exactly, covers the process's whole life).
// A peak shorter than the interval can be missed.
class ResidentSampler {
 public:
  explicit ResidentSampler(std::chrono::milliseconds interval = std::chrono::milliseconds(5));
  ~ResidentSampler();
  ResidentSampler(const ResidentSampler&) = delete;
  ResidentSampler& operator=(const ResidentSampler&) = delete;

  // The most seen since the sampler started or the last take_peak(), the
  // resident size now included; then starts afresh.
  [[nodiscard]] std::size_t take_peak();

 private:
  static void* run(void* self);

  std::atomic<std::size_t> peak_;
  std::chrono::milliseconds interval_;
  std::atomic<bool> stop_{false};
  pthread_t thread_{};
  bool running_ = false;
};

// While it lives, large blocks come from malloc's heap instead of each from
// a mapping of its own, and what is freed stays there for the next block:
// a mapping's pages are cleared by the kernel on first touch, and processing
// takes and drops hundreds of MB of planes from stage to stage (at 12 MP a
// third of its system time went to that). Between stages and at the end,
// give_back_free_memory() returns what is free, so the peak stays what is in
// use. Where the C library is not glibc it does nothing.
class HeapForLargeBlocks {
 public:
  HeapForLargeBlocks();
  ~HeapForLargeBlocks();  // back to glibc's thresholds, and what is free given back
  HeapForLargeBlocks(const HeapForLargeBlocks&) = delete;
  HeapForLargeBlocks& operator=(const HeapForLargeBlocks&) = delete;
};

// The free memory of malloc's heaps returned to the system (malloc_trim).
void give_back_free_memory();

}  // namespace psrig
