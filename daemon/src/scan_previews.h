#pragma once
// The pictures the web catalogue's cards show, made by psrigd from a scan's
// maps on first request and kept beside them (<maps>/../previews/), remade
// when the maps are newer:
//   thumbnail.png  the albedo, cropped to 4:3 and shrunk to 320x240
//   relit.png      the same swatch under a raking light from the upper
//                  left (elevation 30°), shaded per pixel from the normal
//                  map, so the knit or weave stands out on hover

#include <filesystem>
#include <string>

#include "psrig/base/error.h"

namespace psrig::daemon {

enum class ScanPreview { thumbnail, relit };

[[nodiscard]] const char* file_name(ScanPreview preview);

// The preview's file, made (atomically) if missing or older than the maps'
// report.json. bad_input when the maps directory has no albedo.png (or, for
// relit, normal.png): the caller's 404; io_error naming the file otherwise.
[[nodiscard]] Result<std::filesystem::path> scan_preview(
    const std::filesystem::path& maps_directory, ScanPreview preview);

}  // namespace psrig::daemon
