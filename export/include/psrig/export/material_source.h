#pragma once
// What an export is made from: the maps of one material and what is known
// about them (their physical size, sample, time, height range). Built from
// a tile directory (tile.json, `psrig tile`) or a maps directory
// (report.json and the scan's scan.json beside it).

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "psrig/base/error.h"
#include "psrig/formats/scratch_directory.h"

namespace psrig::export_ {

struct MaterialSource {
  std::filesystem::path directory;
  std::filesystem::path albedo;      // albedo.png: 8-bit sRGB colour (required)
  std::filesystem::path normal;      // normal.png: (n + 1) / 2, OpenGL convention (required)
  std::filesystem::path height_exr;  // height.exr: float heights, empty when absent
  std::filesystem::path height_png;  // height.png: 16-bit, height_png_range's low..high
  int width_px = 0;
  int height_px = 0;
  // The pixel's edge; absent: sizes are in pixels (written as 1 px = 1 mm).
  std::optional<double> pixel_size_mm;
  std::string sample_id;           // empty: unknown
  std::string sample_description;  // empty: unknown
  std::string scan_time;           // ISO 8601 UTC, empty: unknown
  // What height.png's 0 and 65535 stand for (report.json height.png_range),
  // in height_units; absent when unknown.
  std::optional<std::pair<double, double>> height_png_range;
  std::string height_units = "mm";  // "mm", or "px" without a pixel size
  bool tile = false;                // made from tile.json: a seamless repeat
  // What is missing and what the export does instead, for the user.
  std::vector<std::string> warnings;

  // A tile's own size in mm (tile.json): its pixels are not quite square,
  // a whole number of repeats resampled to whole pixels.
  std::optional<double> tile_width_mm, tile_height_mm;

  // A tile cut for this export alone lives here, and goes with the last
  // copy of the source; null for maps or a tile already on disk.
  std::shared_ptr<const formats::ScratchDirectory> scratch;

  [[nodiscard]] bool has_height() const { return !height_exr.empty() || !height_png.empty(); }
  // The physical size in mm (pixels when the pixel size is unknown).
  [[nodiscard]] double width_mm() const {
    return tile_width_mm.value_or(width_px * pixel_size_mm.value_or(1.0));
  }
  [[nodiscard]] double height_mm() const {
    return tile_height_mm.value_or(height_px * pixel_size_mm.value_or(1.0));
  }
};


// The material in `directory`: a tile directory when it holds tile.json,
// else a maps directory. Missing albedo or normal maps, an unreadable or
// malformed tile.json/report.json: bad input naming the file and key.
// A maps directory without report.json or without a pixel size is still a
// source, with a warning saying what is missing.
[[nodiscard]] Result<MaterialSource> material_source_from(const std::filesystem::path& directory);

// What an export of `directory` is made from: the tile directory itself
// when given one; for a maps directory its seamless tile, so the material
// repeats without a seam: the one `psrig tile` stored there when it is
// current, else one cut for this export into a scratch directory (the maps
// directory is never written); or the whole scan when `whole_scan` or when
// no tile can be cut from the maps (a warning says why).
[[nodiscard]] Result<MaterialSource> material_for_export(const std::filesystem::path& directory,
                                                         bool whole_scan = false);

}  // namespace psrig::export_
