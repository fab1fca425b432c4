#include "psrig/base/memory_use.h"

#include <cstdio>
#include <fstream>
#include <string>
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
  // /proc/self/statm's second field, resident pages: cheaper than status.
  std::FILE* statm = std::fopen("/proc/self/statm", "r");
  if (statm == nullptr) return 0;
  unsigned long long size = 0;
  unsigned long long resident = 0;
  const int read = std::fscanf(statm, "%llu %llu", &size, &resident);
  std::fclose(statm);
  if (read != 2) return 0;
  return static_cast<std::size_t>(resident) * static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
}

std::size_t peak_resident_bytes() {
  return status_kilobytes("VmHWM");
}

ResidentSampler::ResidentSampler(std::chrono::milliseconds interval) : peak_(resident_bytes()) {
  thread_ = std::thread([this, interval] {
    while (!stop_.load()) {
      raise_to(peak_, resident_bytes());
      std::this_thread::sleep_for(interval);
    }
  });
}

ResidentSampler::~ResidentSampler() {
  stop_ = true;
  thread_.join();
}

std::size_t ResidentSampler::take_peak() {
  const std::size_t now = resident_bytes();
  raise_to(peak_, now);
  return peak_.exchange(now);
}

}  // namespace psrig
