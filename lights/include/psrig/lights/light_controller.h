#pragma once
// The rig's LEDs, behind one small interface; a backend per kind of
// hardware (gpiod, usb, modbus) and the simulated one (sim), all chosen by
// the configuration's `lights.backend`. Device code returns errors, never
// throws. Backends do what they are told; SafeLights (safe_lights.h) keeps
// the rig safe on top of any of them.

#include <memory>
#include <string>

#include "psrig/base/error.h"
#include "psrig/config/rig_config.h"
#include "psrig/lights/switch_log.h"

namespace psrig::lights {

class LightController {
 public:
  virtual ~LightController() = default;

  [[nodiscard]] virtual int channel_count() const = 0;
  // Turns `channel` (0-based) on; the caller has turned every other off.
  [[nodiscard]] virtual Status turn_on(int channel) = 0;
  // Turns every channel off. Must work in any state, as often as called.
  [[nodiscard]] virtual Status all_off() = 0;
  // Brightness of `channel` from 0 to 1, for the next time it is on.
  [[nodiscard]] virtual Status set_intensity(int channel, double level) = 0;
  // "usb strobe controller 1209:5053 serial A17, firmware 1.2" and the like.
  [[nodiscard]] virtual std::string describe() const = 0;

  // What was switched, as the backend saw it through.
  [[nodiscard]] const SwitchLog& log() const { return log_; }

 protected:
  SwitchLog log_;  // backends record every switch that succeeded
};

}  // namespace psrig::lights
