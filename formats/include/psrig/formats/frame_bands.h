#pragma once
// A scan's frames decoded a band of rows at a time, top to bottom, for a
// reader that takes each row once (the pipeline's solve): read_scan_by_band
// leaves the frames allocated but not yet decoded, and each band of each
// frame is decoded just before it is needed, the frames side by side on the
// pool. No frame's compressed file or raw rows are held whole, and the
// decoding runs beside the work on the bands before. Frames psrig's PNG path
// does not take (TIFF, EXR, PNGs with a palette or interlacing) are read
// whole by read_scan_by_band, as read_scan reads them, and have nothing left
// to decode.

#include <cstddef>
#include <filesystem>
#include <memory>

#include "psrig/base/error.h"
#include "psrig/formats/scan.h"
#include "psrig/formats/scan_reader.h"

namespace psrig::formats {

class FrameBands {
 public:
  // Rows [first, first + rows) of frame `index` (scan.frames' order) into
  // its Mat; each frame's bands in order, each once. Damage found in a band
  // is judged as read_scan judges a damaged frame (OpenCV's reader decides:
  // the same bad_input naming the file and key, or the whole frame read by
  // it after all).
  [[nodiscard]] Status decode(std::size_t index, int first, int rows);
  // Whether frame `index` still has rows to decode.
  [[nodiscard]] bool pending(std::size_t index) const;

  FrameBands();
  FrameBands(FrameBands&&) noexcept;
  FrameBands& operator=(FrameBands&&) noexcept;
  ~FrameBands();

  struct State;  // formats' own (src/frame_bands_state.h)
  explicit FrameBands(std::unique_ptr<State> state);

 private:
  std::unique_ptr<State> state_;
};

struct BandedScan {
  Scan scan;  // frames allocated; those FrameBands decodes are not decoded yet
  FrameBands frames;
};

// read_scan's scan, checked as it checks it, with the frames it can decode
// a band at a time left to `frames`. The frames' pixels belong to the scan's
// Mats: keep `scan` and `frames` together.
[[nodiscard]] Result<BandedScan> read_scan_by_band(const std::filesystem::path& directory,
                                                   ScanImages images = ScanImages::all);

}  // namespace psrig::formats
