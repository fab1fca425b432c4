#include "psrig/lights/switch_log.h"

#include <algorithm>
#include <chrono>
#include <set>

namespace psrig::lights {

void SwitchLog::record(int channel, bool on) {
  record({Clock::now(), channel, on});
}

void SwitchLog::record(const SwitchEvent& event) {
  std::lock_guard lock(mutex_);
  events_.push_back(event);
}

std::vector<SwitchEvent> SwitchLog::events() const {
  std::lock_guard lock(mutex_);
  return events_;
}

void SwitchLog::clear() {
  std::lock_guard lock(mutex_);
  events_.clear();
}

std::optional<std::string> SwitchLog::overlap() const {
  std::lock_guard lock(mutex_);
  std::set<int> on;
  for (const auto& event : events_) {
    if (event.channel < 0) {
      if (!event.on) on.clear();
      continue;
    }
    if (event.on) on.insert(event.channel);
    else on.erase(event.channel);
    if (on.size() > 1) {
      std::string channels;
      for (int c : on) channels += (channels.empty() ? "" : ", ") + std::to_string(c);
      const auto since_start =
          std::chrono::duration<double, std::milli>(event.time - events_.front().time).count();
      return "channels " + channels + " on together, " + std::to_string(since_start) + " ms into the log";
    }
  }
  return std::nullopt;
}

std::vector<int> SwitchLog::on_now() const {
  std::lock_guard lock(mutex_);
  std::set<int> on;
  for (const auto& event : events_) {
    if (event.channel < 0) {
      if (!event.on) on.clear();
    } else if (event.on) {
      on.insert(event.channel);
    } else {
      on.erase(event.channel);
    }
  }
  return {on.begin(), on.end()};
}

}  // namespace psrig::lights
