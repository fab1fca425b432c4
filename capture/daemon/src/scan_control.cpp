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

const char* to_string(ScanErrorCode code) {
  switch (code) {
    case ScanErrorCode::none:
      return "none";
    case ScanErrorCode::camera:
      return "camera";
    case ScanErrorCode::lights:
      return "lights";
    case ScanErrorCode::storage:
      return "storage";
    case ScanErrorCode::processing:
      return "processing";
    case ScanErrorCode::aborted:
      return "aborted";
    case ScanErrorCode::queue_full:
      return "queue_full";
    case ScanErrorCode::config:
      return "config";
    case ScanErrorCode::internal:
      return "internal";
  }
  return "unknown";
}

}  // namespace psrig::daemon
