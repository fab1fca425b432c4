#include "psrig/rig/storage_settings.h"

namespace psrig::rig {

formats::StorageOptions storage_options(const config::StorageConfig& storage) {
  formats::StorageOptions options;
  options.exr_compression =
      formats::parse_exr_compression(storage.exr_compression).value_or(options.exr_compression);
  options.png_level = storage.png_level;
  options.map_precision =
      formats::parse_map_precision(storage.map_precision).value_or(options.map_precision);
  return options;
}

}  // namespace psrig::rig
