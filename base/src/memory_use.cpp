#include "psrig/base/memory_use.h"

#include <cstdio>
#include <fcntl.h>
#include <fstream>
#include <malloc.h>
#include <pthread.h>
#include <string>
#include <thread>
#include <unistd.h>

namespace psrig {
namespace {

// A "Key:   123 kB" line of /proc/self/status, in bytes; 0 when absent.
std::size_t status_kilobytes(const std::string& key) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.compare(0, key.size(), key) != 0 || line.size() <= key.size() ||
        line[key.size()] != ':')
      continue;
    try {
      return static_cast<std::size_t>(std::stoull(line.substr(key.size() + 1))) * 1024;
    } catch (const std::exception&) {
      return 0;
    }
  }
  return 0;
}

void raise_to(std::atomic<std::size_t>& peak, std::size_t value) {
  std::size_t seen = peak.load();
  while (value > seen && !peak.compare_exchange_weak(seen, value)) {
  }
}

}  // namespace

std::size_t resident_bytes() {
  // /proc/self/statm's second field, resident pages: cheaper than status,
  // and read with no allocation (the sampler's thread then needs no arena).
  const int fd = ::open("/proc/self/statm", O_RDONLY | O_CLOEXEC);
  if (fd < 0) return 0;
  char text[128];
  const ssize_t n = ::read(fd, text, sizeof text - 1);
  ::close(fd);
  if (n <= 0) return 0;
  text[n] = '\0';
  unsigned long long size = 0;
  unsigned long long resident = 0;
  if (std::sscanf(text, "%llu %llu", &size, &resident) != 2) return 0;
  return static_cast<std::size_t>(resident) * static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
}

std::size_t peak_resident_bytes() {
  return status_kilobytes("VmHWM");
}

ResidentSampler::ResidentSampler(std::chrono::milliseconds interval)
    : peak_(resident_bytes()), interval_(interval) {
  // A small stack: the sampler's thread only reads one /proc file (the
  // default 8 MB would count against an address-space limit).
  pthread_attr_t attributes;
  pthread_attr_init(&attributes);
  pthread_attr_setstacksize(&attributes, 64 * 1024);
  running_ = pthread_create(&thread_, &attributes, &ResidentSampler::run, this) == 0;
  pthread_attr_destroy(&attributes);
}

ResidentSampler::~ResidentSampler() {
  stop_ = true;
  if (running_) pthread_join(thread_, nullptr);
}

void* ResidentSampler::run(void* self) {
  auto& sampler = *static_cast<ResidentSampler*>(self);
  while (!sampler.stop_.load()) {
    raise_to(sampler.peak_, resident_bytes());
    std::this_thread::sleep_for(sampler.interval_);
  }
  return nullptr;
}

std::size_t ResidentSampler::take_peak() {
  const std::size_t now = resident_bytes();
  raise_to(peak_, now);
  return peak_.exchange(now);
}

HeapForLargeBlocks::HeapForLargeBlocks() {
#ifdef __GLIBC__
  mallopt(M_MMAP_THRESHOLD, 1 << 30);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
#endif
}

HeapForLargeBlocks::~HeapForLargeBlocks() {
#ifdef __GLIBC__
  // Setting a threshold ends glibc's own adjusting of it: these are where
  // that takes them (blocks from 32 MB on mapped, the heap trimmed above
  // twice that).
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 64 << 20);
#endif
  give_back_free_memory();
}

void give_back_free_memory() {
#ifdef __GLIBC__
  malloc_trim(0);
#endif
}

}  // namespace psrig
