#pragma once
// What the patch view repeats: the seamless tile of the maps (whole repeats
// of the fabric, the join cross-faded; processing/seamless_tile.h), read
// from MAPS_DIR/tile when `psrig tile` made one, else cut in memory, so
// that the draped sheet shows no seam.

#include <string>

#include "psrig/base/error.h"
#include "psrig/preview/swatch_maps.h"

namespace psrig::preview {

struct PatchTile {
  SwatchMaps maps;     // the tile, or the maps themselves when no tile can be cut
  std::string source;  // where it came from, for the user
  bool periodic = false;
  int repeats_u = 1, repeats_v = 1;
};

// Maps that are not a psrig maps directory (no p.exr, q.exr, albedo.exr)
// are repeated as they are, and `source` says so.
[[nodiscard]] PatchTile patch_tile(const SwatchMaps& maps);

}  // namespace psrig::preview
