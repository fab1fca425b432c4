#include "psrig/preview/scene_motion.h"

#include <cmath>
#include <numbers>

namespace psrig::preview {
namespace {

// The yaw a spin of `speed` braking at `brake` has turned after `elapsed`.
double braked_turn(double speed, double brake, double elapsed) {
  if (elapsed <= 0) return 0;
  if (brake <= 0) return speed * elapsed;
  return speed / brake * (1 - std::exp(-brake * elapsed));
}

}  // namespace

void SceneMotion::kick(double now_s, double deg_per_s) {
  // Fold what the previous kick turned into the offset, then start afresh.
  kick_offset_ += braked_turn(kick_speed_, params_.brake_per_s, now_s - kick_time_s_);
  kick_speed_ = spin(now_s) + deg_per_s;
  kick_time_s_ = now_s;
}

double SceneMotion::spin(double now_s) const {
  const double elapsed = std::max(now_s - kick_time_s_, 0.0);
  return kick_speed_ * std::exp(-params_.brake_per_s * elapsed);
}

SceneView SceneMotion::at(double now_s, SceneView base) const {
  base.light.tilt_deg = std::fmod(base.light.tilt_deg + params_.light_orbit_deg_per_s * now_s, 360);
  const double sway = params_.sway_period_s > 0
                          ? params_.sway_amplitude_deg *
                                std::sin(2 * std::numbers::pi * now_s / params_.sway_period_s)
                          : 0;
  const double spun =
      kick_offset_ + braked_turn(kick_speed_, params_.brake_per_s, now_s - kick_time_s_);
  base.model_yaw_deg = std::fmod(base.model_yaw_deg + sway + spun, 360);
  return base;
}

}  // namespace psrig::preview
