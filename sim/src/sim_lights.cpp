#include "psrig/sim/sim_lights.h"

#include "psrig/lights/switch_log_file.h"
#include "psrig/sim/simulated_leds.h"

namespace psrig::sim {
namespace {

class SimLights final : public lights::LightController {
 public:
  SimLights(int channels, std::vector<double> intensity, std::shared_ptr<SimulatedLeds> leds,
            std::unique_ptr<lights::SwitchLogFile> file)
      : channels_(channels),
        intensity_(std::move(intensity)),
        leds_(std::move(leds)),
        file_(std::move(file)) {
    intensity_.resize(channels_, 1.0);
  }

  int channel_count() const override { return channels_; }

  Status turn_on(int channel) override {
    const auto now = lights::Clock::now();
    leds_->set_led(channel, true, intensity_[channel], now);
    log_.record(channel, true);
    if (file_) file_->record(channel, true, now);
    return {};
  }

  Status all_off() override {
    const auto now = lights::Clock::now();
    leds_->all_off(now);
    log_.record(-1, false);
    // Also from a process that never switched one on (`psrig lights
    // --off` after a crash): the file is the simulated LEDs' only memory
    // across processes.
    if (file_) file_->record(-1, false, now);
    return {};
  }

  Status set_intensity(int channel, double level) override {
    if (channel < 0 || channel >= channels_)
      return std::unexpected(internal_error("sim lights: no channel " + std::to_string(channel)));
    intensity_[channel] = level;
    return {};
  }

  std::string describe() const override {
    return "simulated lights, " + std::to_string(channels_) + " channels";
  }

 private:
  int channels_;
  std::vector<double> intensity_;
  std::shared_ptr<SimulatedLeds> leds_;
  std::unique_ptr<lights::SwitchLogFile> file_;  // lights.sim.switch_log, if set
};

}  // namespace

Result<std::unique_ptr<lights::LightController>> open_sim_lights(const config::RigConfig& config) {
  std::unique_ptr<lights::SwitchLogFile> file;
  if (!config.lights.sim.switch_log.empty()) {
    auto opened = lights::SwitchLogFile::open(config.lights.sim.switch_log);
    if (!opened) return std::unexpected(opened.error());
    file = std::move(*opened);
  }
  return std::make_unique<SimLights>(config.lights.channels, config.lights.intensity,
                                     SimulatedLeds::attach(config), std::move(file));
}

}  // namespace psrig::sim
