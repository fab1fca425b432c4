#pragma once
// Writes scan directories in the psrig-scan/1 layout (docs/design.md "Scan directory"): the rig's
// scans, `psrig synth`'s synthetic ones, and test fixtures.

#include <filesystem>

#include <nlohmann/json.hpp>

#include "psrig/base/error.h"
#include "psrig/formats/scan.h"
#include "psrig/formats/storage_options.h"

namespace psrig::formats {

// scan.json for `scan`: the description's document (unknown keys kept) with
// every key psrig knows rewritten from the description. Images are named
// led<k>, dark, mask, flat<k>, gt_normal, gt_height, with .png for 8- and
// 16-bit images and .exr for float ones.
[[nodiscard]] nlohmann::json scan_json(const Scan& scan);

// Writes the images and scan.json into `directory`, which must not exist
// yet: the directory appears whole, flushed to disk, or not at all.
[[nodiscard]] Status write_scan(const Scan& scan, const std::filesystem::path& directory,
                                const StorageOptions& storage = {});

}  // namespace psrig::formats
