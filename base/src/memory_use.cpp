#include "psrig/base/memory_use.h"

#include <fstream>
#include <string>

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

}  // namespace

std::size_t resident_bytes() {
  return status_kilobytes("VmRSS");
}

std::size_t peak_resident_bytes() {
  return status_kilobytes("VmHWM");
}

bool reset_peak_resident() {
  std::ofstream clear("/proc/self/clear_refs");
  if (!clear) return false;
  clear << "5" << std::flush;
  return static_cast<bool>(clear);
}

}  // namespace psrig
