#pragma once
// rig.toml's [storage] section as the maps' storage options.

#include "psrig/config/rig_config.h"
#include "psrig/formats/storage_options.h"

namespace psrig::rig {

// The compression and precision [storage] asks for (the loader has checked
// the values).
[[nodiscard]] formats::StorageOptions storage_options(const config::StorageConfig& storage);

}  // namespace psrig::rig
