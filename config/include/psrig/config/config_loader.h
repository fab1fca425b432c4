#pragma once
// Loads and checks rig.toml. Errors name the file, line and column, the key
// and what would be right ("file:line:col: key: message"); keys psrig does
// not know are reported as warnings (with the nearest known key), never
// rejected, so a newer file still loads.

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "psrig/base/error.h"
#include "psrig/config/rig_config.h"

namespace psrig::config {

// `warnings` gets one line per unknown key.
[[nodiscard]] Result<RigConfig> load_config(const std::filesystem::path& file,
                                            std::vector<std::string>* warnings = nullptr);

// The same from text; `source` names it in messages, and relative paths
// in it resolve against its directory.
[[nodiscard]] Result<RigConfig> parse_config(std::string_view text,
                                             const std::filesystem::path& source,
                                             std::vector<std::string>* warnings = nullptr);

}  // namespace psrig::config
