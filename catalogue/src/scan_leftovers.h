#pragma once
// What an interrupted run left on disk, and what start-up recovery does
// with it, whichever backend keeps the rows: a whole raw scan (it holds
// scan.json) is kept without its unrecorded maps; anything less is
// removed, as are the scan writer's staging directories of processes that
// are gone. Only inside the rig's own directory of the storage root.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "psrig/base/error.h"

namespace psrig::catalogue {

// A row recovery found `queued` or `running`, and the scan directory it
// names (relative to the storage root; empty when none).
struct UnfinishedScan {
  std::int64_t id = 0;
  std::string scan_path;
};

// What recovery makes of one unfinished scan.
struct InterruptedScan {
  std::int64_t id = 0;
  bool kept = false;        // its whole raw frames stay, its row keeps naming them
  std::string message;      // the row's error message
};

// Cleans up after each scan (its directory under `storage_root`, and its
// writer's staging directory), then the abandoned staging directories in
// `rig_root`; the directories removed are appended to `removed`.
[[nodiscard]] std::vector<InterruptedScan> clean_interrupted_scans(
    const std::filesystem::path& storage_root, const std::filesystem::path& rig_root,
    const std::vector<UnfinishedScan>& unfinished, std::vector<std::filesystem::path>& removed);

// Removes a finished scan's maps and scan directories (only inside the
// storage root): before its row goes, so that no row names missing files.
[[nodiscard]] Status remove_scan_files(const std::filesystem::path& storage_root,
                                       const std::vector<std::filesystem::path>& directories);

}  // namespace psrig::catalogue
