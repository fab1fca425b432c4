#pragma once
// Which simulated rig a configuration describes, and the one instance of a
// simulated device per rig. The simulated backends find their device (the
// LEDs, the world) through the configuration, as a real backend finds its
// device node: every configuration that agrees on the geometry, the number
// of LED channels and the [sim] table opens the same one, so the sim camera
// sees what the sim lights, or a test's emulated driver, switch.

#include <algorithm>
#include <memory>
#include <mutex>
#include <utility>
#include <vector>

#include "psrig/config/rig_config.h"

namespace psrig::sim {

struct SimulatedRig {
  config::Geometry geometry;
  int channels = 3;
  config::SimConfig sim;

  [[nodiscard]] static SimulatedRig of(const config::RigConfig& config) {
    return {config.geometry, config.lights.channels, config.sim};
  }
  bool operator==(const SimulatedRig&) const = default;
};

// One T per simulated rig, alive while anyone holds it (as a device is open
// while a process holds it): a program that closes its rig and opens it
// again starts from a fresh one. Thread-safe.
template <class T>
class SimulatedRigRegistry {
 public:
  // The rig's T, made by `make()` when nobody holds one.
  template <class Make>
  [[nodiscard]] std::shared_ptr<T> attach(const config::RigConfig& config, Make make) {
    const SimulatedRig rig = SimulatedRig::of(config);
    std::lock_guard lock(mutex_);
    std::erase_if(entries_, [](const auto& entry) { return entry.second.expired(); });
    for (const auto& [key, instance] : entries_)
      if (key == rig)
        if (auto held = instance.lock()) return held;
    std::shared_ptr<T> made = make();
    entries_.emplace_back(rig, made);
    return made;
  }

 private:
  std::mutex mutex_;
  std::vector<std::pair<SimulatedRig, std::weak_ptr<T>>> entries_;  // a handful at most
};

}  // namespace psrig::sim
