#include "kiosk_output.h"

namespace psrig::preview::cli {

Result<std::unique_ptr<KioskOutput>> open_kms_output(const KmsArgs&, int) {
  return std::unexpected(processing::io_error("", "the KMS output is not built in yet"));
}

}  // namespace psrig::preview::cli
