#pragma once
// Wall and whole-process CPU time of one piece of work, for the benchmarks
// that report both (the pool's threads count in the CPU time).

#include <chrono>
#include <ctime>

namespace psrig::bench {

// The CPU time of the whole process (every pool thread), in ms.
inline double process_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) / 1e6;
}

struct Times {
  double wall_ms = 0, cpu_ms = 0;
  Times& operator+=(const Times& o) {
    wall_ms += o.wall_ms, cpu_ms += o.cpu_ms;
    return *this;
  }
};

template <class Work>
Times timed(const Work& work) {
  const double cpu = process_cpu_ms();
  const auto start = std::chrono::steady_clock::now();
  work();
  return {
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count(),
      process_cpu_ms() - cpu};
}

}  // namespace psrig::bench
