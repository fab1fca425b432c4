#pragma once
// The seamless tile: every map resampled onto the fabric's deskewed repeat
// lattice, a whole number of repeats wide and high, and the remaining seam
// cross-faded away so that the tile repeats without a visible join. What
// `psrig tile` writes and the preview's patch view repeats (docs/design.md
// "Tile directory").

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "psrig/analysis/fabric_measure.h"
#include "psrig/base/error.h"
#include "psrig/formats/maps_reader.h"
#include "psrig/formats/scan_layout.h"
#include "psrig/formats/storage_options.h"

namespace psrig::analysis {

// The seam check: the tile repeated 2x2; per line (a column, or a row) the
// RMS of the second difference of the height across it. `value` is the
// worst of the four lines that straddle the seams, `bound` the 95th
// percentile of the same over the tile's own interior lines.
struct SeamCheck {
  std::string map;  // "height", or "albedo" for maps without a height
  double value = 0;
  double bound = 0;
  long samples = 0;  // finite second differences on the seam lines
  [[nodiscard]] bool passed() const { return value <= bound; }
};
[[nodiscard]] SeamCheck check_seam(const cv::Mat& map, const std::string& name);

struct TileOptions {
  int repeats = 0;  // each way; 0: as many whole repeats as the scan holds
};

struct Tile {
  formats::Maps maps;  // the tile's maps (report and scan document left empty)
  bool periodic = false;
  std::string message;  // why the tile is the whole scan, when it is
  int repeats_u = 1, repeats_v = 1;
  cv::Point2d origin_px, u_px, v_px;  // the parallelogram cut from the scan
  int band_px = 0;                    // cross-fade width, tile pixels
  std::optional<double> pixel_size_mm;
  double width = 0, height = 0;  // mm, or px without a pixel size
  SeamCheck seam;
};

// `lattice` from find_repeat_lattice, or nullopt for non-periodic maps: then
// the tile is the whole scan with its border cross-faded. Bad input: a
// --repeats that does not fit.
[[nodiscard]] Result<Tile> make_seamless_tile(const formats::Maps& maps,
                                              const std::optional<RepeatLattice>& lattice,
                                              const TileOptions& options = {});

// The tile of `maps`: its repeat found (find_repeat_lattice), the tile cut.
// A fabric with no repeat gets the whole scan with its border cross-faded,
// and a warning saying why; so does a seam the check finds visible.
[[nodiscard]] Result<Tile> cut_tile(const formats::Maps& maps, const TileOptions& options,
                                    std::vector<std::string>& warnings);

// The tile stored with a maps directory, `maps_directory/tile` (`psrig
// tile` writes it), when there is one at least as new as the maps'
// report.json; nothing otherwise. Only finds: cutting and writing a tile
// is `psrig tile`'s step, never a reader's.
[[nodiscard]] std::optional<std::filesystem::path> stored_tile(
    const std::filesystem::path& maps_directory);

// tile.json.
[[nodiscard]] nlohmann::json tile_json(const Tile& tile);

// Writes the tile's maps (the maps directory's names) and tile.json into
// `directory`, which appears whole or not at all; an earlier tile there is
// replaced, anything else refused. Compressed as `storage` says (the maps
// directory's defaults unless given).
[[nodiscard]] Status write_tile(const Tile& tile, const std::filesystem::path& directory,
                                const formats::StorageOptions& storage = {});

}  // namespace psrig::analysis
