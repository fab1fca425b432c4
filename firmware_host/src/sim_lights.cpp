#include "psrig/firmware_host/sim_lights.h"

#include "psrig/firmware_host/simulated_leds.h"

namespace psrig::firmware_host {
namespace {

class SimLights final : public LightController {
 public:
  SimLights(int channels, std::vector<double> intensity, std::shared_ptr<SimulatedLeds> leds)
      : channels_(channels), intensity_(std::move(intensity)), leds_(std::move(leds)) {
    intensity_.resize(channels_, 1.0);
  }

  int channel_count() const override { return channels_; }

  Status turn_on(int channel) override {
    leds_->set_led(channel, true, intensity_[channel]);
    log_.record(channel, true);
    return {};
  }

  Status all_off() override {
    leds_->all_off();
    log_.record(-1, false);
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
};

}  // namespace

std::unique_ptr<LightController> open_sim_lights(const config::RigConfig& config) {
  return std::make_unique<SimLights>(config.lights.channels, config.lights.intensity,
                                     SimulatedLeds::attach(config));
}

}  // namespace psrig::firmware_host
