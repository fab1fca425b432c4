#include "fault_recording_devices.h"

namespace psrig::daemon {
namespace {

template <class T>
T noted(T result, std::atomic<bool>& failed) {
  if (!result) failed = true;
  return result;
}

class FaultRecordingCamera final : public cameras::Camera {
 public:
  FaultRecordingCamera(std::unique_ptr<cameras::Camera> inner, std::shared_ptr<DeviceFaults> faults)
      : inner_(std::move(inner)), faults_(std::move(faults)) {}
  Status configure(const config::CameraConfig& settings) override {
    return noted(inner_->configure(settings), faults_->camera);
  }
  Status start() override { return noted(inner_->start(), faults_->camera); }
  Result<cameras::Frame> grab(std::chrono::milliseconds timeout) override {
    return noted(inner_->grab(timeout), faults_->camera);
  }
  Status stop() override { return noted(inner_->stop(), faults_->camera); }
  std::string describe() const override { return inner_->describe(); }
  void describe_scene(formats::Scan& scan) const override { inner_->describe_scene(scan); }

 private:
  std::unique_ptr<cameras::Camera> inner_;
  std::shared_ptr<DeviceFaults> faults_;
};

class FaultRecordingLights final : public lights::LightController {
 public:
  FaultRecordingLights(std::unique_ptr<LightController> inner, std::shared_ptr<DeviceFaults> faults)
      : inner_(std::move(inner)), faults_(std::move(faults)) {}
  int channel_count() const override { return inner_->channel_count(); }
  // SafeLights reads this decorator's log: it records what went through.
  Status turn_on(int channel) override {
    auto ok = noted(inner_->turn_on(channel), faults_->lights);
    if (ok) log_.record(channel, true);
    return ok;
  }
  Status all_off() override {
    auto ok = noted(inner_->all_off(), faults_->lights);
    if (ok) log_.record(-1, false);
    return ok;
  }
  Status set_intensity(int channel, double level) override {
    return noted(inner_->set_intensity(channel, level), faults_->lights);
  }
  std::string describe() const override { return inner_->describe(); }

 private:
  std::unique_ptr<LightController> inner_;
  std::shared_ptr<DeviceFaults> faults_;
};

}  // namespace

std::unique_ptr<cameras::Camera> record_camera_faults(std::unique_ptr<cameras::Camera> camera,
                                                      std::shared_ptr<DeviceFaults> faults) {
  return std::make_unique<FaultRecordingCamera>(std::move(camera), std::move(faults));
}

std::unique_ptr<lights::LightController> record_light_faults(
    std::unique_ptr<lights::LightController> lights, std::shared_ptr<DeviceFaults> faults) {
  return std::make_unique<FaultRecordingLights>(std::move(lights), std::move(faults));
}

}  // namespace psrig::daemon
