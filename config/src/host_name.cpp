#include <unistd.h>

#include "psrig/config/rig_config.h"

namespace psrig::config {

std::string host_name() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "";
  return name;
}

}  // namespace psrig::config
