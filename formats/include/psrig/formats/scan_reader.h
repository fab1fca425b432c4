#pragma once
// Reads and validates a psrig-scan/1 directory. Every problem comes back as
// a bad_input Error naming the file and the scan.json key.

#include <filesystem>

#include "psrig/base/error.h"
#include "psrig/formats/scan.h"

namespace psrig::formats {

// Lights whose matrix is worse conditioned than this are refused: noise
// would be amplified that many times into the normals.
inline constexpr double kMaxLightConditionNumber = 1000.0;

// Parses and checks scan.json only (no images are opened).
[[nodiscard]] Result<ScanDescription> read_scan_description(const std::filesystem::path& directory);

// What read_scan reads of the images scan.json names: all, or all but the
// ground truth (the simulator's, 192 MB at 12 MP), which processing reads
// when it needs it, with read_ground_truth.
enum class ScanImages { all, without_ground_truth };

// scan.json plus every image it names, read in parallel and cross-checked.
[[nodiscard]] Result<Scan> read_scan(const std::filesystem::path& directory,
                                     ScanImages images = ScanImages::all);

// One ground-truth image scan.json names, read into `scan` and checked as
// read_scan checks it against `frames`, the frames' size (the frames may be
// gone by then); nothing to do when scan.json names none or `scan` already
// holds it. `scan.description.directory` is where it is.
enum class GroundTruth { normal, height };
[[nodiscard]] Status read_ground_truth(Scan& scan, GroundTruth which, cv::Size frames);

// The scan write_scan has just stored in `directory`, as read_scan would
// read it back, without reading it: scan.json's description parsed from the
// document written, the images kept in memory (write_scan stores them
// losslessly), the same checks. What the rig hands to processing.
[[nodiscard]] Result<Scan> as_stored(Scan scan, const std::filesystem::path& directory);

}  // namespace psrig::formats
