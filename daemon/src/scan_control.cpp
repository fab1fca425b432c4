#include "psrig/daemon/scan_control.h"

namespace psrig::daemon {

const char* to_string(DaemonState state) {
  switch (state) {
    case DaemonState::starting:
      return "starting";
    case DaemonState::idle:
      return "idle";
    case DaemonState::scanning:
      return "scanning";
    case DaemonState::processing:
      return "processing";
    case DaemonState::error:
      return "error";
    case DaemonState::stopping:
      return "stopping";
  }
  return "unknown";
}

}  // namespace psrig::daemon
