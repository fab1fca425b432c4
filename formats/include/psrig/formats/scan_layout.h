#pragma once
// The scan directory and its maps directory, file by file (docs/design.md
// "Scan directory", "Maps directory"): the contract between capture, which
// writes scans, processing, which reads them and writes maps, and the
// daemon, which catalogues and serves both. Only this header spells their
// file names.

#include <string>
#include <string_view>

namespace psrig::formats {

// A scan directory: scan.json and the frames it names.
namespace scan_files {
inline constexpr const char* kDescription = "scan.json";
// Where a scan's maps go unless told otherwise: inside the scan directory.
inline constexpr const char* kMapsDirectory = "maps";
inline constexpr const char* kMask = "mask.png";
inline constexpr const char* kGroundTruthNormal = "gt_normal.exr";  // (x, y, z) as RGB
inline constexpr const char* kGroundTruthHeight = "gt_height.exr";
// Frame file extensions a scan may use; what the rig writes: a PNG for
// integer frames, an EXR for float ones.
inline constexpr std::string_view kFrameExtensions[] = {".png", ".tif", ".tiff", ".exr"};

// The frame of LED `k` as the rig names it, for pixels of `depth` (a
// CV_8U, CV_16U or CV_32F depth).
[[nodiscard]] std::string led_frame(int k, int depth);
[[nodiscard]] std::string dark_frame(int depth);
[[nodiscard]] std::string flat_frame(int k, int depth);
// The flat-field frame of light `k` with `extension` (one of kFrameExtensions):
// a scan.json that names no flats may still hold flat0.png, flat1.png, …
[[nodiscard]] std::string flat_frame(int k, std::string_view extension);

// Whether `name` is a file the rig writes into a scan directory (any frame
// extension, any light number).
[[nodiscard]] bool is_scan_file(std::string_view name);
}  // namespace scan_files

// A maps directory.
namespace map_files {
inline constexpr const char* kAlbedoPng = "albedo.png";
inline constexpr const char* kAlbedoExr = "albedo.exr";
inline constexpr const char* kNormalPng = "normal.png";
// The normal map in DirectX's convention (+Y down), on request (psrig process
// --normal-convention directx): Substance and Unreal take it as is.
inline constexpr const char* kNormalDirectxPng = "normal_directx.png";
inline constexpr const char* kP = "p.exr";
inline constexpr const char* kQ = "q.exr";
inline constexpr const char* kHeightExr = "height.exr";
inline constexpr const char* kHeightPng = "height.png";
inline constexpr const char* kMask = "mask.png";
inline constexpr const char* kReport = "report.json";
// Every file of a maps directory, in the order a listing shows them.
inline constexpr const char* kAll[] = {kAlbedoPng, kAlbedoExr,       kNormalPng, kP,
                                       kQ,         kHeightExr,       kHeightPng, kMask,
                                       kReport,    kNormalDirectxPng};

[[nodiscard]] bool is_map_file(std::string_view name);
}  // namespace map_files

// The seamless tile (`psrig tile`): a directory of the maps' files cut at
// whole repeats, described by tile.json.
namespace tile_files {
inline constexpr const char* kFormat = "psrig-tile/1";
inline constexpr const char* kDescription = "tile.json";
// Where `psrig tile` writes unless told: inside the maps directory, so that
// reprocessing (which replaces the maps directory) drops a stale tile.
inline constexpr const char* kDirectory = "tile";
}  // namespace tile_files

}  // namespace psrig::formats
