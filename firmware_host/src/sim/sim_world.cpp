#include "psrig/firmware_host/sim/sim_world.h"

#include <algorithm>
#include <cmath>

#include "psrig/firmware_host/sim/lambertian_render.h"
#include "psrig/processing/light_matrix.h"

namespace psrig::firmware_host {
namespace {

// Older switches than this many are folded into the state they left: a
// kiosk runs for months, its world must not grow.
constexpr std::size_t kMaxHistory = 4096;

sim::Swatch make_world_swatch(const config::SimConfig& sim) {
  sim::SwatchParams params;
  params.pattern = sim::parse_swatch_pattern(sim.pattern).value_or(sim::SwatchPattern::jersey);
  params.size = {sim.width, sim.height};
  params.pixel_size_mm = sim.pixel_size_mm;
  params.seed = sim.seed;
  return sim::make_swatch(params);
}

}  // namespace

SimWorld::SimWorld(const config::RigConfig& config) : swatch_(make_world_swatch(config.sim)) {
  for (int k = 0; k < config.lights.channels; ++k) {
    const auto& tilts = config.geometry.tilts_deg;
    const double tilt_deg =
        k < static_cast<int>(tilts.size()) ? tilts[k] : 360.0 * k / config.lights.channels;
    directions_.push_back(processing::light_direction(tilt_deg, config.geometry.slant_deg));
    radiance_.push_back(sim::render_lambertian(swatch_, {directions_.back(), {1, 1, 1}}, true));
  }
  // Room light: a bright overcast sky, so a facet sees (1 + n_z) / 2 of it.
  std::vector<cv::Mat> normal;
  cv::split(swatch_.normal, normal);
  cv::Mat sky = (normal[2] + 1) * 0.5;
  cv::Mat sky3;
  cv::merge(std::vector<cv::Mat>{sky, sky, sky}, sky3);
  ambient_ = swatch_.albedo.mul(sky3);
}

void SimWorld::set_led(int channel, bool on, double level, Clock::time_point at) {
  std::lock_guard lock(mutex_);
  history_.push_back({at, channel, on, std::clamp(level, 0.0, 1.0)});
  log_.record(channel, on);
  if (history_.size() > kMaxHistory) {
    // Fold the oldest half into one entry per channel that is on.
    const std::size_t keep_from = history_.size() / 2;
    std::vector<Switch> folded;
    std::vector<std::pair<bool, double>> state(directions_.size(), {false, 0.0});
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

void SimWorld::all_off(Clock::time_point at) {
  std::lock_guard lock(mutex_);
  history_.push_back({at, -1, false, 0});
  log_.record(-1, false);
}

std::vector<int> SimWorld::leds_on() const {
  std::vector<double> level(directions_.size(), 0);
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

std::vector<double> SimWorld::exposure_weights(Clock::time_point begin,
                                               Clock::time_point end) const {
  const std::size_t n = directions_.size();
  std::vector<double> weights(n, 0.0);
  const double span = std::chrono::duration<double>(end - begin).count();
  if (span <= 0) return weights;
  std::vector<double> level(n, 0.0);  // the state as time advances
  Clock::time_point now = begin;
  const auto accumulate = [&](Clock::time_point until) {
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

}  // namespace psrig::firmware_host
