#pragma once
// The daemon's rig, open between scans: opened (and opened again) by the
// scan worker, with every device call recorded so a failed scan is blamed
// on the right device, and the LEDs switched off on request from any
// thread, through the open rig or, with it closed, through the light
// backend opened alone for it.

#include <memory>
#include <mutex>
#include <string>

#include "psrig/base/error.h"
#include "psrig/config/rig_config.h"
#include "psrig/daemon/scan_control.h"
#include "psrig/rig/rig.h"

namespace psrig::daemon {

struct DeviceFaults;

// What the status page says of the devices.
struct DeviceStatus {
  bool open = false;
  std::string lights;  // the backend's description, when open
  std::string camera;
  std::string open_error;  // why the last attempt to open them failed
  // Why the last attempt to switch every LED off failed (closing the rig,
  // or lights-off with the rig closed): an LED may still be on. Cleared
  // when switching them off next succeeds. Also shown in open_error.
  std::string lights_off_error;
};

class RigHolder {
 public:
  RigHolder();
  ~RigHolder();
  RigHolder(const RigHolder&) = delete;
  RigHolder& operator=(const RigHolder&) = delete;

  // The worker's: opens the rig with `config` unless it is open; on
  // failure `code` says which part to blame (lights, camera or config).
  [[nodiscard]] Status open(const config::RigConfig& config, catalogue::ScanErrorCode& code);
  // The worker's: every LED off (a failure is logged and shown), then the
  // rig closed.
  void close();
  // The worker's, while open.
  [[nodiscard]] rig::Rig& rig() { return *rig_; }

  // Whether the camera or the light backend failed since clear_faults().
  [[nodiscard]] bool camera_failed() const;
  [[nodiscard]] bool lights_failed() const;
  void clear_faults();

  // Any thread: every LED off, through the open rig, or with the rig
  // closed through the light backend `config` names, opened alone for it.
  [[nodiscard]] Status lights_off(const config::RigConfig& config);

  [[nodiscard]] DeviceStatus devices() const;

 private:
  // Records (for devices()) whether switching the LEDs off worked.
  Status note_lights_off(Status off, const std::string& device);

  // Held while the light backend is being opened (the rig, or the lights
  // alone to switch them off), so that one device is never opened twice at
  // once. Taken before rig_mutex_ and devices_mutex_, never after.
  std::mutex open_mutex_;
  // Only the worker replaces the rig; others (lights_off) use its lights
  // under this lock while it is open.
  mutable std::mutex rig_mutex_;
  std::unique_ptr<rig::Rig> rig_;
  std::shared_ptr<DeviceFaults> faults_;

  mutable std::mutex devices_mutex_;
  DeviceStatus devices_;
};

}  // namespace psrig::daemon
