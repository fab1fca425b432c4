#include "psrig/config/rig_config.h"

namespace psrig::config {

bool is_shared_catalogue(const CatalogueConfig& catalogue) {
  // libpq takes both spellings of its URI scheme.
  return catalogue.url.starts_with("postgresql://") || catalogue.url.starts_with("postgres://");
}

}  // namespace psrig::config
