#pragma once
// The solve a band of rows at a time, each band's maps encoded as soon as it
// is solved: albedo.exr, albedo.png, p.exr, q.exr, normal.png (and
// normal_directx.png), mask.png stream to their files (formats/row_writer.h)
// while the next band is solved beside them. What is kept whole is only what
// the later stages need: p, q, the residual and the flags; of the albedo,
// the part the fabric measurement reads. No encoded map, half-float copy or
// whole albedo is ever held: at 12 MP colour, 400 MB less than solving first
// and encoding after.

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "map_files.h"
#include "psrig/base/error.h"
#include "psrig/base/log.h"
#include "psrig/formats/frame_bands.h"
#include "psrig/processing/woodham.h"

namespace psrig::processing {

struct SolvedPlanes {
  cv::Mat p, q, residual, flags;  // the whole scan's, as solve() gives them
  cv::Mat albedo_centre;          // the albedo as solved over analysis::measured_region
};

struct BandStage {
  SolvedPlanes planes;
  double solve_ms = 0;   // solving, summed over the bands
  double decode_ms = 0;  // decoding the frames' bands, summed over frames and bands
  // Each map's encoder (encoding its rows and writing them), summed over the
  // bands, in the order the maps are listed above.
  std::vector<std::pair<std::string, double>> encode_ms;
};

// Solves `scan` into `files.dir`'s maps. `frames`: the scan's frames still
// to decode (formats::read_scan_by_band's), each band decoded beside the
// solve of the band before and the maps of the one before that. `colour`:
// the rig's colour calibration (camera RGB to linear sRGB), applied to the
// albedo the maps hold (not to albedo_centre). The scan's frames (and dark
// frame and mask) are used up: the memory of their rows goes back as the
// bands pass, where the scan alone holds them, and those rows read as 0 after.
[[nodiscard]] Result<BandStage> solve_and_encode(formats::Scan& scan, formats::FrameBands& frames,
                                                 const SolveOptions& options, const MapFiles& files,
                                                 const std::optional<cv::Matx33d>& colour,
                                                 spdlog::logger& log);

}  // namespace psrig::processing
