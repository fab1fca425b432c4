#pragma once
// Reads and validates a psrig-scan/1 directory. Every problem comes back as
// a bad_input Error naming the file and the scan.json key.

#include <filesystem>

#include "psrig/base/error.h"
#include "psrig/processing/scan.h"

namespace psrig::processing {

// Lights whose matrix is worse conditioned than this are refused: noise
// would be amplified that many times into the normals.
inline constexpr double kMaxLightConditionNumber = 1000.0;

// Parses and checks scan.json only (no images are opened).
[[nodiscard]] Result<ScanDescription> read_scan_description(const std::filesystem::path& directory);

// scan.json plus every image it names, read in parallel and cross-checked.
[[nodiscard]] Result<Scan> read_scan(const std::filesystem::path& directory);

}  // namespace psrig::processing
