#pragma once
// Which maps the kiosk shows: the newest finished scan of a catalogue
// directory. A scan counts once its maps directory holds report.json, the
// processing step's last file, so a scan still being written is never
// picked up half done.

#include <filesystem>
#include <optional>

namespace psrig::preview {

// The maps directory of the newest scan under `catalogue`: DIR/*/maps
// (scan directories) or DIR/* (maps directories), newest by report.json's
// modification time; nullopt when there is none yet (or no such directory).
[[nodiscard]] std::optional<std::filesystem::path> newest_maps(
    const std::filesystem::path& catalogue);

}  // namespace psrig::preview
