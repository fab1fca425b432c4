#pragma once
// Process-wide last resort: on SIGINT or SIGTERM every SafeLights alive is
// switched off at once, from a thread of its own, before anything else
// happens; so is it on std::terminate. Programs that drive lights call
// install_emergency_stop() first thing in main, before any other thread
// exists (the signals are blocked in every thread but the watcher's).

#include <functional>

namespace psrig::lights {

class SafeLights;

// `on_signal` runs after the lights are off (e.g. to ask a scan to stop).
// A second signal while the program is still running ends it at once.
void install_emergency_stop(std::function<void(int signal)> on_signal = {});

// A signal has arrived.
[[nodiscard]] bool stop_requested();

// SafeLights registers itself; nothing else needs to.
void register_lights(SafeLights* lights);
void unregister_lights(SafeLights* lights);
// Switches every registered SafeLights off.
void emergency_all_off();

}  // namespace psrig::lights
