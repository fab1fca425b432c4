#pragma once
// LEDs wired to lines of an emulated GPIO chip: which line lights which of
// the simulated world's LEDs, and at which level. Connected to a chip, it
// switches the world's LEDs as the lines change, so the real gpiod backend
// lights the simulated swatch.

#include <algorithm>
#include <memory>
#include <vector>

#include "emulated_gpio_chip.h"
#include "psrig/firmware_host/sim/sim_world.h"

namespace psrig::test {

struct GpioLedWiring {
  std::vector<unsigned> lines;  // the line of each LED, in channel order
  bool active_low = false;      // an LED is lit when its line is low

  [[nodiscard]] bool lit(const std::vector<int>& levels, int channel) const {
    return levels[lines[channel]] == (active_low ? 0 : 1);
  }
  [[nodiscard]] int lit_count(const std::vector<int>& levels) const {
    int count = 0;
    for (int channel = 0; channel < static_cast<int>(lines.size()); ++channel)
      count += lit(levels, channel) ? 1 : 0;
    return count;
  }
  // The most LEDs ever lit together in a chip's record of its levels.
  [[nodiscard]] int most_lit(const std::vector<std::vector<int>>& history) const {
    int most = 0;
    for (const auto& levels : history) most = std::max(most, lit_count(levels));
    return most;
  }

  // From now on `chip` switches `world`'s LEDs: those going dark first, then
  // those lighting up, as the wires would within one register write.
  void connect(EmulatedGpioChip& chip, std::shared_ptr<firmware_host::SimWorld> world) const {
    chip.set_listener([wiring = *this, world](const std::vector<int>& before,
                                              const std::vector<int>& after) {
      const int channels = static_cast<int>(wiring.lines.size());
      for (int channel = 0; channel < channels; ++channel)
        if (wiring.lit(before, channel) && !wiring.lit(after, channel))
          world->set_led(channel, false);
      for (int channel = 0; channel < channels; ++channel)
        if (!wiring.lit(before, channel) && wiring.lit(after, channel))
          world->set_led(channel, true);
    });
  }
};

}  // namespace psrig::test
