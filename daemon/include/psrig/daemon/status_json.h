#pragma once
// What GET /v1/status answers, and what a rig writes of itself to the
// catalogue's rigs list (RigPresence): one description of a psrigd's state.

#include <nlohmann/json.hpp>

#include "psrig/daemon/scan_service.h"

namespace psrig::daemon {

[[nodiscard]] nlohmann::json status_json(ScanService& service);

}  // namespace psrig::daemon
