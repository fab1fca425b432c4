#include "psrig/daemon/storage_budget.h"

#include <algorithm>
#include <cstdio>
#include <string>

namespace psrig::daemon {
namespace {

namespace fs = std::filesystem;

// Room the catalogue keeps after a scan: its rows for this scan (and for
// a failure) go to SQLite's write-ahead log, which needs space to grow.
constexpr std::uintmax_t kCatalogueHeadroom = 1 << 20;

std::string human_bytes(std::uintmax_t bytes) {
  char text[32];
  if (bytes >= (1U << 20))
    std::snprintf(text, sizeof text, "%.1f MiB", static_cast<double>(bytes) / (1 << 20));
  else
    std::snprintf(text, sizeof text, "%.0f KiB", static_cast<double>(bytes) / (1 << 10));
  return text;
}

// What one scan and its maps take on disk, over-estimated: every frame
// (each LED's and the dark) as 16-bit colour, the simulator's ground truth
// (float normals and heights) and the maps (about 30 bytes a pixel). 0
// when the frame size is the camera's own, known only once it has scanned.
std::uintmax_t expected_scan_bytes(const config::RigConfig& config) {
  const bool sim = config.camera.backend == "sim";
  int width = config.camera.width, height = config.camera.height;
  if ((width <= 0 || height <= 0) && sim) {
    width = config.sim.width;
    height = config.sim.height;
  }
  if (width <= 0 || height <= 0) return 0;
  const auto frames =
      static_cast<std::uintmax_t>(config.lights.channels + (config.capture.dark_frame ? 1 : 0));
  std::uintmax_t per_pixel = frames * 3 * 2;
  if (sim) per_pixel += 16;
  if (config.capture.process) per_pixel += 32;
  return static_cast<std::uintmax_t>(width) * static_cast<std::uintmax_t>(height) * per_pixel;
}

// What a finished scan takes on disk, maps included.
std::uintmax_t tree_bytes(const fs::path& directory) {
  std::uintmax_t bytes = 0;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(directory, ec), end; !ec && it != end;
       it.increment(ec)) {
    std::error_code size_ec;
    if (it->is_regular_file(size_ec)) bytes += it->file_size(size_ec);
  }
  return bytes;
}

}  // namespace

Status StorageBudget::check(const config::RigConfig& config) const {
  std::error_code ec;
  const auto space = fs::space(root_, ec);
  if (ec) return std::unexpected(io_error(root_, "cannot read the free space: " + ec.message()));
  const std::uintmax_t scan = std::max(expected_scan_bytes(config), last_scan_bytes_);
  const std::uintmax_t needed = scan + kCatalogueHeadroom;
  if (space.available >= needed) return {};
  return std::unexpected(io_error(
      root_, "not enough free space for a scan: " + human_bytes(space.available) +
                 " free, a scan needs about " + human_bytes(scan) + " and the catalogue " +
                 human_bytes(kCatalogueHeadroom) +
                 " (LEDs not switched on); delete or move old scans, or point storage.root at a "
                 "larger disk"));
}

void StorageBudget::record_scan(const fs::path& scan_directory, const fs::path& maps_directory) {
  last_scan_bytes_ = tree_bytes(scan_directory);
  if (!maps_directory.empty() && maps_directory.parent_path() != scan_directory)
    last_scan_bytes_ += tree_bytes(maps_directory);
}

}  // namespace psrig::daemon
