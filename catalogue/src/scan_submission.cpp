#include "psrig/catalogue/scan_submission.h"

namespace psrig::catalogue {

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

}  // namespace psrig::catalogue
