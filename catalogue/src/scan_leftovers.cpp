#include "scan_leftovers.h"

#include <cerrno>
#include <signal.h>
#include <unistd.h>

#include "catalogue_rows.h"
#include "psrig/base/log.h"
#include "psrig/formats/atomic_directory.h"
#include "psrig/formats/scan_layout.h"

namespace psrig::catalogue {
namespace {

namespace fs = std::filesystem;
using formats::AtomicDirectory;

bool process_alive(pid_t pid) {
  return ::kill(pid, 0) == 0 || errno != ESRCH;
}

}  // namespace

std::vector<InterruptedScan> clean_interrupted_scans(const fs::path& storage_root,
                                                     const fs::path& rig_root,
                                                     const std::vector<UnfinishedScan>& unfinished,
                                                     std::vector<fs::path>& removed) {
  auto log = logger("catalogue");
  const auto remove_directory = [&](const fs::path& directory) {
    std::error_code failed;
    if (!fs::exists(fs::symlink_status(directory, failed))) return;
    fs::remove_all(directory, failed);
    if (failed) {
      log->warn("cannot remove {}: {}", directory.string(), failed.message());
      return;
    }
    removed.push_back(directory);
    log->info("removed {}, left by an interrupted scan", directory.string());
  };
  std::vector<InterruptedScan> interrupted;
  std::error_code ec;
  for (const auto& [id, scan_path] : unfinished) {
    bool kept = false;
    // Resolved in the shared root, acted on only inside this rig's own.
    if (const auto directory =
            scan_path.empty() ? std::nullopt : rows::inside_root(rig_root, storage_root / scan_path)) {
      // A scan directory is renamed into place whole, flushed, from its
      // staging directory: one that holds scan.json is a whole raw
      // capture, which cannot be repeated. It stays; only its maps, which
      // no row recorded and which may not have reached the disk, go.
      std::error_code type_ec;
      kept = !fs::is_symlink(*directory, type_ec) && fs::is_directory(*directory, type_ec) &&
             fs::is_regular_file(*directory / formats::scan_files::kDescription, type_ec);
      if (kept) {
        std::vector<fs::path> maps;
        for (fs::directory_iterator it(*directory, ec), end; !ec && it != end; it.increment(ec)) {
          const auto staging = AtomicDirectory::parse_staging(it->path());
          if (it->path().filename() == formats::scan_files::kMapsDirectory ||
              (staging && staging->target == formats::scan_files::kMapsDirectory))
            maps.push_back(it->path());
        }
        for (const auto& path : maps)
          remove_directory(path);
      } else {
        remove_directory(*directory);
      }
      // Its writer's staging directory, whoever's PID it carries: no scan
      // of this daemon is running yet.
      std::vector<fs::path> staging;
      for (fs::directory_iterator it(directory->parent_path(), ec), end; !ec && it != end;
           it.increment(ec))
        if (const auto name = AtomicDirectory::parse_staging(it->path());
            name && name->target == directory->filename())
          staging.push_back(it->path());
      for (const auto& path : staging)
        remove_directory(path);
    }
    interrupted.push_back(
        {id, kept,
         kept ? "interrupted during processing; raw frames kept, reprocess with psrig process"
              : "interrupted: psrigd stopped before this scan finished"});
  }
  // Other writers' staging directories, once their process is gone: in
  // this rig's directory only (another rig's PIDs mean nothing here).
  std::vector<fs::path> abandoned;
  for (fs::directory_iterator it(rig_root, ec), end; !ec && it != end; it.increment(ec)) {
    const auto staging = AtomicDirectory::parse_staging(it->path());
    std::error_code type_ec;
    if (staging && staging->writer != ::getpid() && !process_alive(staging->writer) &&
        !it->is_symlink(type_ec) && it->is_directory(type_ec))
      abandoned.push_back(it->path());
  }
  for (const auto& path : abandoned)
    remove_directory(path);
  return interrupted;
}

Status remove_scan_files(const fs::path& storage_root, const std::vector<fs::path>& directories) {
  for (const auto& directory : directories) {
    const auto inside = rows::inside_root(storage_root, directory);
    if (!inside) continue;
    std::error_code ec;
    fs::remove_all(*inside, ec);
    if (ec) return std::unexpected(io_error(*inside, "cannot remove: " + ec.message()));
  }
  return {};
}

}  // namespace psrig::catalogue
