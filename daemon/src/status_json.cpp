#include "psrig/daemon/status_json.h"

#include "psrig/calibration/calibration_status.h"

namespace psrig::daemon {

nlohmann::json status_json(ScanService& service) {
  using nlohmann::json;
  const DaemonStatus s = service.status();
  const DeviceStatus d = service.devices();
  const config::RigConfig config = service.config();
  const auto optional_id = [](const std::optional<std::int64_t>& id) {
    return id ? json(*id) : json(nullptr);
  };
  return {
      {"rig", service.catalogue().rig_name()},
      {"role", config.daemon.role},
      {"catalogue", service.catalogue().backend()},
      {"state", to_string(s.state)},
      {"step", s.step},
      {"progress_percent", s.progress_percent},
      {"current_scan", optional_id(s.current_scan)},
      {"last_scan", optional_id(s.last_scan)},
      {"last_error",
       {{"code", static_cast<int>(s.last_error_code)},
        {"code_name", to_string(s.last_error_code)},
        {"message", s.last_error}}},
      {"scans_completed", s.scans_completed},
      {"scans_failed", s.scans_failed},
      {"queue_length", s.queue_length},
      {"queue_limit", config.daemon.queue_limit},
      {"uptime_s", std::chrono::duration<double>(s.uptime).count()},
      {"devices",
       {{"open", d.open}, {"lights", d.lights}, {"camera", d.camera}, {"error", d.open_error}}},
      // Where this rig's scans go: its own directory of a shared root.
      {"storage_root", config.storage.root.string()},
      {"calibration",
       calibration::to_json(calibration::calibration_status(
           calibration::CalibrationStore(config.storage.root), config.calibration.max_age_days))}};
}

}  // namespace psrig::daemon
