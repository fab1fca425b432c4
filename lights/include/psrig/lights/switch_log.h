#pragma once
// Every LED switch a light controller makes, with its time, so that tests
// (and a curious engineer) can check the rig's first promise: never two
// LEDs on at once.

#include <chrono>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace psrig::lights {

using Clock = std::chrono::steady_clock;

struct SwitchEvent {
  Clock::time_point time;
  int channel = -1;  // -1: every channel (only with on == false)
  bool on = false;
};

class SwitchLog {
 public:
  void record(int channel, bool on);
  // An event as it happened elsewhere (read back from a file, say).
  void record(const SwitchEvent& event);
  [[nodiscard]] std::vector<SwitchEvent> events() const;
  void clear();

  // Replays the events: empty when at no time two channels were on, else a
  // description of the first moment they were.
  [[nodiscard]] std::optional<std::string> overlap() const;
  // The channels on after the last event (empty: all off).
  [[nodiscard]] std::vector<int> on_now() const;

 private:
  mutable std::mutex mutex_;
  std::vector<SwitchEvent> events_;
};

}  // namespace psrig::lights
