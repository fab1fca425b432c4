#pragma once
// Room on the storage root for the next scan: checked before any LED goes
// on, so a full disk fails a scan before its frames are taken, not after.
// A scan is expected to take what the configuration says at most, or what
// the last one took, whichever is more. The worker's.

#include <cstdint>
#include <filesystem>

#include "psrig/base/error.h"
#include "psrig/config/rig_config.h"

namespace psrig::daemon {

class StorageBudget {
 public:
  explicit StorageBudget(std::filesystem::path root) : root_(std::move(root)) {}

  // Room for one more scan under `config` and its catalogue rows; the
  // error says how much is free and what to do.
  [[nodiscard]] Status check(const config::RigConfig& config) const;

  // A scan finished: what it and its maps (when kept elsewhere) take.
  void record_scan(const std::filesystem::path& scan_directory,
                   const std::filesystem::path& maps_directory);

 private:
  std::filesystem::path root_;
  std::uintmax_t last_scan_bytes_ = 0;  // on disk, maps included
};

}  // namespace psrig::daemon
