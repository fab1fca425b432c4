#include "psrig/preview/newest_scan.h"

#include <system_error>

#include "psrig/formats/scan_layout.h"

namespace psrig::preview {

std::optional<std::filesystem::path> newest_maps(const std::filesystem::path& catalogue) {
  namespace fs = std::filesystem;
  std::optional<fs::path> newest;
  fs::file_time_type newest_time;
  std::error_code error;  // scans come and go while we look: skip what vanished
  for (const auto& entry : fs::directory_iterator(catalogue, error)) {
    if (!entry.is_directory(error)) continue;
    for (const fs::path& maps :
         {entry.path() / formats::scan_files::kMapsDirectory, entry.path()}) {
      const auto written = fs::last_write_time(maps / formats::map_files::kReport, error);
      if (error) continue;
      if (!newest || written > newest_time || (written == newest_time && maps > *newest)) {
        newest = maps;
        newest_time = written;
      }
      break;
    }
  }
  return newest;
}

}  // namespace psrig::preview
