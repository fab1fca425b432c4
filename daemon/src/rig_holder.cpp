#include "psrig/daemon/rig_holder.h"

#include <exception>

#include "fault_recording_devices.h"
#include "psrig/base/log.h"

namespace psrig::daemon {

RigHolder::RigHolder() : faults_(std::make_shared<DeviceFaults>()) {}

RigHolder::~RigHolder() {
  close();
}

Status RigHolder::open(const config::RigConfig& config, catalogue::ScanErrorCode& code) {
  if (rig_) return {};
  std::lock_guard open_lock(open_mutex_);
  auto log = logger("daemon");
  auto faults = std::make_shared<DeviceFaults>();
  const auto failed = [&](catalogue::ScanErrorCode what, const Error& error) -> Status {
    code = what;
    log->error("cannot open the {}: {}", to_string(what), error.describe());
    std::lock_guard lock(devices_mutex_);
    devices_ = {false, "", "", error.describe(), devices_.lights_off_error};
    return std::unexpected(error);
  };
  const rig::RigWrappers record_faults{
      .lights = [&](auto lights) { return record_light_faults(std::move(lights), faults); },
      .camera = [&](auto camera) { return record_camera_faults(std::move(camera), faults); },
  };
  Result<rig::Rig> opened = std::unexpected(internal_error("the rig was not opened"));
  try {
    opened = rig::open_rig(config, /*with_camera=*/true, record_faults);
  } catch (const std::exception& e) {
    return failed(catalogue::ScanErrorCode::config,
                  internal_error(std::string("opening the rig: ") + e.what()));
  }
  if (!opened) {
    const catalogue::ScanErrorCode what = opened.error().code == ErrorCode::camera
                                              ? catalogue::ScanErrorCode::camera
                                              : catalogue::ScanErrorCode::lights;
    return failed(what, opened.error());
  }
  auto rig = std::make_unique<rig::Rig>(std::move(*opened));
  {
    std::lock_guard lock(devices_mutex_);
    devices_ = {true, rig->lights->describe(), rig->camera->describe(), devices_.lights_off_error,
                devices_.lights_off_error};
  }
  log->info("rig open: {}; {}", rig->lights->describe(), rig->camera->describe());
  std::lock_guard lock(rig_mutex_);
  rig_ = std::move(rig);
  faults_ = std::move(faults);
  return {};
}

void RigHolder::close() {
  std::unique_ptr<rig::Rig> closing;
  {
    std::lock_guard lock(rig_mutex_);
    closing = std::move(rig_);
  }
  if (closing) {
    // SafeLights turns every LED off as it goes, but says nothing if that
    // fails: asked here first, so that a failure is logged and shown.
    if (auto off = note_lights_off(closing->lights->all_off(), closing->lights->describe()); !off)
      logger("daemon")->error("closing the rig: {}", off.error().describe());
  }
  closing.reset();
  std::lock_guard lock(devices_mutex_);
  devices_.open = false;
}

bool RigHolder::camera_failed() const {
  return faults_->camera;
}

bool RigHolder::lights_failed() const {
  return faults_->lights;
}

void RigHolder::clear_faults() {
  faults_->clear();
}

Status RigHolder::note_lights_off(Status off, const std::string& device) {
  std::lock_guard lock(devices_mutex_);
  if (off) {
    if (!devices_.lights_off_error.empty()) {
      logger("daemon")->info("{}: every LED is off again", device);
      if (devices_.open_error == devices_.lights_off_error) devices_.open_error.clear();
      devices_.lights_off_error.clear();
    }
    return off;
  }
  Error error = off.error();
  error.message =
      "switching every LED off on " + device + " failed (one may still be on): " + error.message;
  devices_.lights_off_error = error.describe();
  devices_.open_error = devices_.lights_off_error;
  return std::unexpected(error);
}

Status RigHolder::lights_off(const config::RigConfig& config) {
  std::lock_guard open_lock(open_mutex_);
  {
    std::lock_guard lock(rig_mutex_);
    if (rig_) return note_lights_off(rig_->lights->all_off(), rig_->lights->describe());
  }
  // Closed: SafeLights switched them off as it went, or tried to; a failure
  // there is not known to be fixed, so the light backend is opened alone to
  // make sure.
  const std::string backend = "the LED backend '" + config.lights.backend + "'";
  auto lights = rig::open_rig(config, /*with_camera=*/false);
  if (!lights) return note_lights_off(std::unexpected(lights.error()), backend);
  return note_lights_off(lights->lights->all_off(), lights->lights->describe());
}

DeviceStatus RigHolder::devices() const {
  std::lock_guard lock(devices_mutex_);
  return devices_;
}

}  // namespace psrig::daemon
