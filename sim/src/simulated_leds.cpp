#include "psrig/sim/simulated_leds.h"

#include <algorithm>
#include <utility>

#include "psrig/sim/simulated_rig.h"

namespace psrig::sim {
namespace {

// Older switches than this many are folded into the state they left: a
// kiosk runs for months, its LEDs' history must not grow.
constexpr std::size_t kMaxHistory = 4096;

}  // namespace

SimulatedLeds::SimulatedLeds(int channels) : channels_(std::max(channels, 0)) {}

std::shared_ptr<SimulatedLeds> SimulatedLeds::attach(const config::RigConfig& config) {
  static SimulatedRigRegistry<SimulatedLeds> registry;
  return registry.attach(config,
                         [&] { return std::make_shared<SimulatedLeds>(config.lights.channels); });
}

void SimulatedLeds::set_led(int channel, bool on, double level, lights::Clock::time_point at) {
  std::lock_guard lock(mutex_);
  history_.push_back({at, channel, on, std::clamp(level, 0.0, 1.0)});
  log_.record(channel, on);
  if (history_.size() > kMaxHistory) {
    // Fold the oldest half into one entry per channel that is on.
    const std::size_t keep_from = history_.size() / 2;
    std::vector<Switch> folded;
    std::vector<std::pair<bool, double>> state(static_cast<std::size_t>(channels_), {false, 0.0});
    for (std::size_t i = 0; i < keep_from; ++i) {
      const auto& s = history_[i];
      if (s.channel < 0)
        std::fill(state.begin(), state.end(), std::pair{false, 0.0});
      else if (s.channel < static_cast<int>(state.size()))
        state[s.channel] = {s.on, s.level};
    }
    const auto when = history_[keep_from - 1].time;
    folded.push_back({when, -1, false, 0});
    for (std::size_t k = 0; k < state.size(); ++k)
      if (state[k].first) folded.push_back({when, static_cast<int>(k), true, state[k].second});
    folded.insert(folded.end(), history_.begin() + static_cast<std::ptrdiff_t>(keep_from),
                  history_.end());
    history_ = std::move(folded);
  }
}

void SimulatedLeds::all_off(lights::Clock::time_point at) {
  std::lock_guard lock(mutex_);
  history_.push_back({at, -1, false, 0});
  log_.record(-1, false);
}

std::vector<int> SimulatedLeds::leds_on() const {
  std::vector<double> level(static_cast<std::size_t>(channels_), 0);
  std::lock_guard lock(mutex_);
  for (const auto& s : history_) {
    if (s.channel < 0)
      std::fill(level.begin(), level.end(), 0.0);
    else if (s.channel < static_cast<int>(level.size()))
      level[s.channel] = s.on ? std::max(s.level, 1e-9) : 0.0;
  }
  std::vector<int> on;
  for (std::size_t k = 0; k < level.size(); ++k)
    if (level[k] > 0) on.push_back(static_cast<int>(k));
  return on;
}

std::vector<double> SimulatedLeds::exposure_weights(lights::Clock::time_point begin,
                                                    lights::Clock::time_point end) const {
  const auto n = static_cast<std::size_t>(channels_);
  std::vector<double> weights(n, 0.0);
  const double span = std::chrono::duration<double>(end - begin).count();
  if (span <= 0) return weights;
  std::vector<double> level(n, 0.0);  // the state as time advances
  lights::Clock::time_point now = begin;
  const auto accumulate = [&](lights::Clock::time_point until) {
    if (until <= now) return;
    const double seconds = std::chrono::duration<double>(std::min(until, end) - now).count();
    for (std::size_t k = 0; k < n; ++k)
      weights[k] += level[k] * seconds;
    now = std::min(until, end);
  };
  std::lock_guard lock(mutex_);
  for (const auto& s : history_) {
    if (s.time > begin) accumulate(s.time);
    if (now >= end) break;
    if (s.channel < 0)
      std::fill(level.begin(), level.end(), 0.0);
    else if (s.channel < static_cast<int>(n))
      level[s.channel] = s.on ? s.level : 0.0;
  }
  accumulate(end);
  for (auto& w : weights)
    w /= span;
  return weights;
}

}  // namespace psrig::sim
