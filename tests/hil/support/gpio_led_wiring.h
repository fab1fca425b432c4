#pragma once
// LEDs wired to lines of an emulated GPIO chip: which line drives which LED,
// and at which level it lights. Reads the chip's line levels as LEDs, and
// connected to the chip, reports each LED that lights up or goes dark, so
// that the real gpiod backend can switch the simulated rig's LEDs.

#include <algorithm>
#include <functional>
#include <memory>
#include <vector>

#include "emulated_gpio_chip.h"
#include "psrig/sim/simulated_leds.h"

namespace psrig::test {

struct GpioLedWiring {
  std::vector<unsigned> lines;  // the line of each LED, in channel order
  bool active_low = false;      // an LED is lit when its line is low

  // An LED lit (true) or gone dark; called on the testbed's handler thread.
  using LedSwitch = std::function<void(int channel, bool lit)>;

  [[nodiscard]] int channels() const { return static_cast<int>(lines.size()); }
  [[nodiscard]] bool lit(const std::vector<int>& levels, int channel) const {
    return levels.at(lines.at(channel)) == (active_low ? 0 : 1);
  }
  // The channels lit at these levels, in order.
  [[nodiscard]] std::vector<int> lit_channels(const std::vector<int>& levels) const {
    std::vector<int> lit_now;
    for (int channel = 0; channel < channels(); ++channel)
      if (lit(levels, channel)) lit_now.push_back(channel);
    return lit_now;
  }
  // The most LEDs lit together anywhere in a chip's record of its levels.
  [[nodiscard]] int most_lit(const std::vector<std::vector<int>>& history) const {
    std::size_t most = 0;
    for (const auto& levels : history)
      most = std::max(most, lit_channels(levels).size());
    return static_cast<int>(most);
  }

  // From now on every change of `chip`'s lines that lights or darkens an
  // LED calls `on_switch`: LEDs going dark first, then those lighting up.
  // (That order forgives a backend that swaps LEDs in one write; the
  // chip's history() does not, and the tests check it.)
  void connect(EmulatedGpioChip& chip, LedSwitch on_switch) const {
    chip.set_listener([wiring = *this, on_switch = std::move(on_switch)](
                          const std::vector<int>& before, const std::vector<int>& after) {
      for (int channel = 0; channel < wiring.channels(); ++channel)
        if (wiring.lit(before, channel) && !wiring.lit(after, channel)) on_switch(channel, false);
      for (int channel = 0; channel < wiring.channels(); ++channel)
        if (!wiring.lit(before, channel) && wiring.lit(after, channel)) on_switch(channel, true);
    });
  }

  // Switches the simulated rig's LEDs (SimulatedLeds::attach with the
  // test's configuration, as the sim camera finds them), at full level:
  // GPIO is on or off.
  [[nodiscard]] static LedSwitch to_leds(std::shared_ptr<sim::SimulatedLeds> leds) {
    return [leds = std::move(leds)](int channel, bool lit) { leds->set_led(channel, lit); };
  }
};

}  // namespace psrig::test
